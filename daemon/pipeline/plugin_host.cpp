#include "pipeline/plugin_host.hpp"

#include "pipeline/plugin_trust.hpp"

#include <unistd.h>

#include <dlfcn.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdio>
#include <string_view>
#include <utility>

namespace cobridge::pipeline {

namespace {

class PluginCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "cobridge.plugin"; }
  std::string message(int ev) const override {
    switch (static_cast<PluginErrc>(ev)) {
      case PluginErrc::kFileNotFound: return "plugin file not found";
      case PluginErrc::kNotTrusted: return "plugin file not trusted";
      case PluginErrc::kNotLoadable: return "not a loadable shared object";
      case PluginErrc::kNoEntryPoint: return "no " COBRIDGE_PLUGIN_ENTRY " entry point";
      case PluginErrc::kCreateFailed: return "plugin create failed";
      case PluginErrc::kNullOps: return "plugin returned no ops table";
      case PluginErrc::kAbiTooNew: return "plugin ABI newer than the host";
      case PluginErrc::kBadOps: return "malformed plugin ops table";
      case PluginErrc::kStartFailed: return "plugin start failed";
    }
    return "unknown plugin error";
  }
};

// Whether an ops table of `size` bytes contains the member at `offset`.
constexpr bool covers(std::uint32_t size, std::size_t offset) noexcept {
  return static_cast<std::size_t>(size) >= offset + sizeof(void (*)());
}

void default_log(LogLevel level, std::string_view instance, std::string_view message) {
  static constexpr std::array<const char*, 6> kNames = {"trace", "debug", "info", "warn", "error", "critical"};
  const auto i = static_cast<std::size_t>(level);
  std::fprintf(stderr, "[plugin %.*s] %s: %.*s\n", static_cast<int>(instance.size()), instance.data(),
               i < kNames.size() ? kNames[i] : "?", static_cast<int>(message.size()), message.data());
}

}  // namespace

const std::error_category& plugin_category() noexcept {
  static const PluginCategory category;
  return category;
}

std::error_code make_error_code(PluginErrc e) noexcept { return {static_cast<int>(e), plugin_category()}; }

// A missing file is not found; a newer ABI is unsupported by this host; a
// start that fails is a failure of the running plugin; the rest are a file
// or settings the host or the plugin refuses (bad input).
Errc plugin_error_kind(PluginErrc e) noexcept {
  switch (e) {
    case PluginErrc::kFileNotFound: return Errc::kNotFound;
    case PluginErrc::kNotTrusted: return Errc::kPermissionDenied;
    case PluginErrc::kAbiTooNew: return Errc::kUnsupported;
    case PluginErrc::kStartFailed: return Errc::kFailed;
    case PluginErrc::kNotLoadable:
    case PluginErrc::kNoEntryPoint:
    case PluginErrc::kCreateFailed:
    case PluginErrc::kNullOps:
    case PluginErrc::kBadOps: return Errc::kInvalidArgument;
  }
  return Errc::kInternal;
}

// ---------------------------------------------------------------------------
// SharedLibrary

Result<SharedLibrary> SharedLibrary::open(const std::filesystem::path& file) {
  dlerror();  // clear a stale message so the one read below is ours
  void* handle = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) {
    const char* why = dlerror();
    return Error(Errc::kUnavailable, why != nullptr ? why : "dlopen failed", file.string());
  }
  return SharedLibrary(handle);
}

SharedLibrary::~SharedLibrary() { close(); }

SharedLibrary::SharedLibrary(SharedLibrary&& other) noexcept : handle_(std::exchange(other.handle_, nullptr)) {}

SharedLibrary& SharedLibrary::operator=(SharedLibrary&& other) noexcept {
  if (this != &other) {
    close();
    handle_ = std::exchange(other.handle_, nullptr);
  }
  return *this;
}

Result<void*> SharedLibrary::symbol(const char* name) const {
  if (handle_ == nullptr) return Error(Errc::kInternal, "no library open", name);
  dlerror();
  void* sym = dlsym(handle_, name);
  if (sym == nullptr) {
    const char* why = dlerror();
    return Error(Errc::kNotFound, why != nullptr ? why : "symbol not found", name);
  }
  return sym;
}

void SharedLibrary::close() noexcept {
  if (handle_ != nullptr) {
    dlclose(handle_);
    handle_ = nullptr;
  }
}

// ---------------------------------------------------------------------------
// PluginHost

namespace {
// [a-z][a-z0-9_]*: it becomes part of a Prometheus metric name.
bool valid_stat_name(std::string_view name) {
  if (name.empty() || name.size() > 64 || name[0] < 'a' || name[0] > 'z') return false;
  for (const char c : name)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) return false;
  return true;
}
}  // namespace

struct PluginHost::Instance {
  PluginHost* owner = nullptr;
  std::string name;
  std::filesystem::path file;
  std::string where;  // of its errors (PluginSpec::where)
  SharedLibrary library;
  cobridge_host_api api{};
  void* self = nullptr;
  // The ops the host may call, read once from the table within its
  // struct_size; optional ops the plugin's ABI lacks stay null.
  int (*start)(void*) = nullptr;
  void (*stop)(void*) = nullptr;
  void (*destroy)(void*) = nullptr;
  void (*on_samples)(void*, const cobridge_sample*, std::size_t) = nullptr;
  void (*on_device)(void*, const cobridge_device_info*) = nullptr;
  std::size_t (*stats)(void*, cobridge_stat*, std::size_t) = nullptr;
  void (*on_role)(void*, const cobridge_role_info*) = nullptr;
  void (*on_bus)(void*, const cobridge_bus_info*) = nullptr;
  std::string type;
  bool started = false;
};

PluginHost::PluginHost(Options options) : options_(std::move(options)) {
  if (!options_.log) options_.log = default_log;
}

PluginHost::~PluginHost() { unload_all(); }

std::filesystem::path PluginHost::resolve(const PluginSpec& spec) const {
  // Only a file name (the loader refuses paths): never outside the plugin directory.
  if (!spec.file.empty()) return options_.plugin_dir / spec.file.filename();
  return options_.plugin_dir / ("libcobridge_" + spec.type + ".so");
}

void PluginHost::log_trampoline(void* host, int level, const char* msg) noexcept {
  const auto* p = static_cast<const Instance*>(host);
  if (p == nullptr || msg == nullptr) return;
  if (level < COBRIDGE_LOG_TRACE) level = COBRIDGE_LOG_TRACE;
  if (level > COBRIDGE_LOG_CRITICAL) level = COBRIDGE_LOG_CRITICAL;
  try {
    p->owner->options_.log(static_cast<LogLevel>(level), p->name, msg);
  } catch (...) {
    // A failing log sink must not unwind into C code.
  }
}

int PluginHost::submit_trampoline(void* host, const cobridge_command* command) noexcept {
  const auto* p = static_cast<const Instance*>(host);
  if (p == nullptr || command == nullptr) return COBRIDGE_COMMAND_FAILED;
  // Every field this host reads exists from the first version of the struct
  // (ABI 2); a shorter one is not a command.
  if (command->struct_size < offsetof(cobridge_command, value) + sizeof(command->value)) {
    return COBRIDGE_COMMAND_UNSUPPORTED;
  }
  const CommandSink& sink = p->owner->options_.commands;
  if (!sink) return COBRIDGE_COMMAND_UNSUPPORTED;
  try {
    return sink(p->name, *command);
  } catch (...) {
    return COBRIDGE_COMMAND_FAILED;  // nothing may unwind into C code
  }
}

// The instance's own log names it already: the line is the message alone.
void PluginHost::report(const std::string& instance, const Error& e) const {
  if (options_.log_failures) options_.log(LogLevel::kError, instance, e.message);
}

Error PluginHost::fail(const Instance& p, PluginErrc code, const std::string& reason) const {
  Error e(plugin_error_kind(code), p.file.string() + ": " + reason, p.where, make_error_code(code));
  report(p.name, e);
  return e;
}

// Checks the file, opens it and finds its entry point.
Error PluginHost::open_library(Instance& p, cobridge_plugin_create_fn& create) const {
  std::error_code fs_ec;
  if (!std::filesystem::exists(p.file, fs_ec)) {
    return fail(p, PluginErrc::kFileNotFound, "file not found");
  }
  if (const Error distrust = plugin_distrust(p.file, ::geteuid()))
    return fail(p, PluginErrc::kNotTrusted, "refused: " + distrust.message);
  Result<SharedLibrary> library = SharedLibrary::open(p.file);
  if (!library.ok())
    return fail(p, PluginErrc::kNotLoadable, "not a loadable shared object (" + library.error().message + ")");
  p.library = std::move(library).value();

  const Result<void*> entry_point = p.library.symbol(COBRIDGE_PLUGIN_ENTRY);
  if (!entry_point.ok()) {
    return fail(p, PluginErrc::kNoEntryPoint,
                "no entry point " COBRIDGE_PLUGIN_ENTRY " (" + entry_point.error().message + ")");
  }
  void* entry = entry_point.value();
  // dlsym hands out functions as void*; POSIX guarantees the round trip.
  create = reinterpret_cast<cobridge_plugin_create_fn>(entry);
  return {};
}

// Fills in the instance's host API and calls the plugin's create.
Error PluginHost::create_instance(Instance& p, const PluginSpec& spec, cobridge_plugin_create_fn create,
                                  const cobridge_plugin_ops*& ops, void*& self) const {
  p.api.abi_version = COBRIDGE_PLUGIN_ABI_VERSION;
  p.api.struct_size = sizeof(cobridge_host_api);
  p.api.host = &p;
  p.api.log = &PluginHost::log_trampoline;
  p.api.gateway_id = options_.gateway_id.c_str();
  p.api.submit_command = &PluginHost::submit_trampoline;
  p.api.redundancy_node = options_.redundancy_node;

  std::array<char, 512> err{};
  const int rc = create(&p.api, spec.config_toml.data(), spec.config_toml.size(), &ops, &self, err.data(),
                        err.size());
  err.back() = '\0';  // a plugin that fills the buffer without terminating it
  if (rc != 0) {
    std::string reason = "create failed: ";
    reason += err[0] != '\0' ? std::string(err.data()) : "code " + std::to_string(rc);
    return fail(p, PluginErrc::kCreateFailed, reason);
  }
  if (ops == nullptr) {
    // Without a table there is no destroy to call; the instance (if any) leaks
    // rather than being freed with the wrong allocator.
    return fail(p, PluginErrc::kNullOps, "create succeeded but returned no ops table");
  }
  return {};
}

// abi_version and struct_size open the table in every version, and destroy
// sits at the same offset in all of them: that is what lets the host refuse
// a table and still free the instance.
Error PluginHost::check_ops(const Instance& p, const cobridge_plugin_ops& ops, void* self) const {
  const std::uint32_t size = ops.struct_size;
  const auto unwind = [&] {
    if (covers(size, offsetof(cobridge_plugin_ops, destroy)) && ops.destroy != nullptr) ops.destroy(self);
  };
  if (ops.abi_version > COBRIDGE_PLUGIN_ABI_VERSION) {
    unwind();
    return fail(p, PluginErrc::kAbiTooNew, "plugin ABI version " + std::to_string(ops.abi_version) +
                                               " is newer than the host's " +
                                               std::to_string(COBRIDGE_PLUGIN_ABI_VERSION));
  }
  if (size < COBRIDGE_PLUGIN_OPS_MIN_SIZE) {
    unwind();
    return fail(p, PluginErrc::kBadOps, "ops table struct_size " + std::to_string(size) + " is below the minimum " +
                                            std::to_string(COBRIDGE_PLUGIN_OPS_MIN_SIZE));
  }
  if (ops.start == nullptr || ops.stop == nullptr || ops.destroy == nullptr || ops.on_samples == nullptr) {
    unwind();
    return fail(p, PluginErrc::kBadOps, "ops table lacks a mandatory op (start, stop, destroy, on_samples)");
  }
  return {};
}

Error PluginHost::load(const PluginSpec& spec) {
  auto p = std::make_unique<Instance>();
  p->owner = this;
  p->name = spec.instance.empty() ? spec.type : spec.instance;
  p->file = resolve(spec);
  p->where = spec.where.empty() ? "plugin '" + p->name + "'" : spec.where;

  cobridge_plugin_create_fn create = nullptr;
  if (Error e = open_library(*p, create)) return e;
  const cobridge_plugin_ops* ops = nullptr;
  void* self = nullptr;
  if (Error e = create_instance(*p, spec, create, ops, self)) return e;
  if (Error e = check_ops(*p, *ops, self)) return e;

  const std::uint32_t size = ops->struct_size;
  p->self = self;
  p->start = ops->start;
  p->stop = ops->stop;
  p->destroy = ops->destroy;
  p->on_samples = ops->on_samples;
  if (covers(size, offsetof(cobridge_plugin_ops, on_device))) p->on_device = ops->on_device;
  if (covers(size, offsetof(cobridge_plugin_ops, stats))) p->stats = ops->stats;
  if (covers(size, offsetof(cobridge_plugin_ops, on_role))) p->on_role = ops->on_role;
  if (covers(size, offsetof(cobridge_plugin_ops, on_bus))) p->on_bus = ops->on_bus;

  const char* type = ops->name != nullptr ? ops->name : "?";
  p->type = type;
  options_.log(LogLevel::kInfo, p->name,
               "loaded " + p->file.string() + " (plugin " + type + ", ABI " + std::to_string(ops->abi_version) + ")");
  const std::lock_guard lock(roster_mutex_);
  plugins_.push_back(std::move(p));
  return {};
}

std::vector<Error> PluginHost::load_all(std::span<const PluginSpec> specs) {
  std::vector<Error> errors;
  for (const auto& spec : specs) {
    if (Error e = load(spec)) errors.push_back(std::move(e));
  }
  return errors;
}

std::vector<Error> PluginHost::start_all() {
  const std::lock_guard lock(roster_mutex_);
  std::vector<Error> errors;
  for (auto it = plugins_.begin(); it != plugins_.end();) {
    Instance& p = **it;
    if (p.started) {
      ++it;
      continue;
    }
    const int rc = p.start(p.self);
    if (rc == 0) {
      p.started = true;
      ++it;
      continue;
    }
    Error e(plugin_error_kind(PluginErrc::kStartFailed),
            p.file.string() + ": start failed (code " + std::to_string(rc) + ")", p.where,
            make_error_code(PluginErrc::kStartFailed));
    report(p.name, e);
    errors.push_back(std::move(e));
    unload(p);
    it = plugins_.erase(it);
  }
  return errors;
}

void PluginHost::deliver(std::span<const Sample> samples) noexcept {
  if (samples.empty()) return;
  for (const auto& p : plugins_) {
    if (p->started) p->on_samples(p->self, samples.data(), samples.size());
  }
}

void PluginHost::announce(const cobridge_device_info& info) noexcept {
  for (const auto& p : plugins_) {
    if (p->started && p->on_device != nullptr) p->on_device(p->self, &info);
  }
}

void PluginHost::announce_role(const cobridge_role_info& info) noexcept {
  for (const auto& p : plugins_) {
    if (p->started && p->on_role != nullptr) p->on_role(p->self, &info);
  }
}

void PluginHost::announce_bus(const cobridge_bus_info& info) noexcept {
  for (const auto& p : plugins_) {
    if (p->started && p->on_bus != nullptr) p->on_bus(p->self, &info);
  }
}

void PluginHost::stop_all() noexcept {
  const std::lock_guard lock(roster_mutex_);
  for (auto it = plugins_.rbegin(); it != plugins_.rend(); ++it) {
    Instance& p = **it;
    if (p.started) {
      p.stop(p.self);
      p.started = false;
    }
  }
}

void PluginHost::unload(Instance& p) noexcept {
  if (p.started) {
    p.stop(p.self);
    p.started = false;
  }
  p.destroy(p.self);
  p.self = nullptr;
  // Only now: the plugin's code must stay mapped until destroy returned.
  p.library.close();
}

void PluginHost::unload_all() noexcept {
  stop_all();
  const std::lock_guard lock(roster_mutex_);
  while (!plugins_.empty()) {
    unload(*plugins_.back());
    plugins_.pop_back();
  }
}

std::size_t PluginHost::started_count() const noexcept {
  std::size_t n = 0;
  for (const auto& p : plugins_) n += p->started ? 1u : 0u;
  return n;
}

std::vector<OutputStats> PluginHost::stats() const {
  const std::lock_guard lock(roster_mutex_);
  std::vector<OutputStats> out;
  std::array<cobridge_stat, kMaxStats> figures{};
  for (const auto& p : plugins_) {
    OutputStats o{p->name, p->type, p->started, {}};
    if (p->started && p->stats != nullptr) {
      const std::size_t n = std::min(p->stats(p->self, figures.data(), figures.size()), figures.size());
      for (std::size_t i = 0; i < n; ++i) {
        const cobridge_stat& f = figures[i];
        if (f.name == nullptr || !valid_stat_name(f.name)) continue;  // a name that cannot be a metric
        o.figures.push_back({f.name, f.help != nullptr ? f.help : "", f.kind == COBRIDGE_STAT_COUNTER, f.value});
      }
    }
    out.push_back(std::move(o));
  }
  return out;
}

std::vector<std::string> PluginHost::instances() const {
  std::vector<std::string> names;
  names.reserve(plugins_.size());
  for (const auto& p : plugins_) names.push_back(p->name);
  return names;
}

}  // namespace cobridge::pipeline
