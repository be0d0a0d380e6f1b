// PluginHost: loads the configured output plugins (shared libraries speaking
// the C ABI of include/cobridge/plugin.h), starts them, hands them the
// dispatcher's sample batches and device announcements, and stops and unloads
// them in reverse order.
//
// Loading is dlopen -> dlsym(COBRIDGE_PLUGIN_ENTRY) -> create -> check the
// ops table, unwinding in reverse on any failure (destroy if created, then
// dlclose). A plugin that fails is reported once, with a code and a message
// naming the file and the reason, and left out; it never takes the other
// plugins down. The host never calls an op beyond the plugin's
// ops->struct_size, so plugins built for an older ABI keep working.
//
// Thread contract: load / start_all / stop_all / unload_all and the
// destructor run on the control thread while the dispatcher is not
// delivering; deliver and announce run on the dispatcher thread (the hot
// path: noexcept, no allocation, no locks — the cost is the plugins' own).
// The log sink and the command sink are called from whatever thread a
// plugin logs or submits on.
#pragma once

#include "base/result.hpp"
#include "pipeline/sample.hpp"

#include <cobridge/plugin.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace cobridge::pipeline {

enum class PluginErrc {
  kFileNotFound = 1,  // no such file in the plugin directory
  kNotTrusted,        // owner or mode of the file or its directory (plugin_trust.hpp): never opened
  kNotLoadable,       // dlopen refused it (not a shared object, missing dependency, ...)
  kNoEntryPoint,      // the library does not export COBRIDGE_PLUGIN_ENTRY
  kCreateFailed,      // the entry point returned non-zero (message is the plugin's)
  kNullOps,           // create succeeded but returned no ops table
  kAbiTooNew,         // ops->abi_version is newer than the host's
  kBadOps,            // struct_size below the mandatory part, or a mandatory op is NULL
  kStartFailed,       // ops->start returned non-zero
};

[[nodiscard]] const std::error_category& plugin_category() noexcept;
[[nodiscard]] std::error_code make_error_code(PluginErrc e) noexcept;

// A failed plugin is reported as the project's Error: code = the PluginErrc,
// message = "<file>: <reason>", where = PluginSpec::where (or
// "plugin '<instance>'"), kind from the PluginErrc (plugin_error_kind).
[[nodiscard]] Errc plugin_error_kind(PluginErrc e) noexcept;

// What the configuration says about one plugin instance.
struct PluginSpec {
  // Instance name, used in logs; unique per host.
  std::string instance;
  // Plugin type; the default file is "libcobridge_<type>.so".
  std::string type;
  // Overrides the file; relative paths are resolved in the plugin directory.
  std::filesystem::path file;
  // The instance's configuration table as TOML text (see plugin.h).
  std::string config_toml;
  // Where the caller's configuration names this instance ("cobridge.toml:40:1:
  // [outputs.dds]"): the `where` of its errors. Empty: "plugin '<instance>'".
  // (Initialized so that {instance, type, file, config} stays warning-free.)
  std::string where = {};
};

// RAII owner of one dlopen handle. Move-only; closing happens last, after
// every object created from the library is gone.
class SharedLibrary {
 public:
  SharedLibrary() noexcept = default;
  // RTLD_NOW so that unresolved symbols fail here, not mid-delivery;
  // RTLD_LOCAL so that plugins cannot see each other's symbols. A failure
  // (kUnavailable) carries dlerror()'s text.
  [[nodiscard]] static Result<SharedLibrary> open(const std::filesystem::path& file);
  ~SharedLibrary();
  SharedLibrary(SharedLibrary&& other) noexcept;
  SharedLibrary& operator=(SharedLibrary&& other) noexcept;
  SharedLibrary(const SharedLibrary&) = delete;
  SharedLibrary& operator=(const SharedLibrary&) = delete;

  [[nodiscard]] explicit operator bool() const noexcept { return handle_ != nullptr; }
  // The symbol, or (kNotFound) dlerror()'s text when it is absent.
  [[nodiscard]] Result<void*> symbol(const char* name) const;
  void close() noexcept;

 private:
  explicit SharedLibrary(void* handle) noexcept : handle_(handle) {}
  void* handle_ = nullptr;
};

enum class LogLevel : int {
  kTrace = COBRIDGE_LOG_TRACE,
  kDebug = COBRIDGE_LOG_DEBUG,
  kInfo = COBRIDGE_LOG_INFO,
  kWarn = COBRIDGE_LOG_WARN,
  kError = COBRIDGE_LOG_ERROR,
  kCritical = COBRIDGE_LOG_CRITICAL,
};

// What one output instance reports about itself (ABI 3 ops->stats).
struct OutputFigure {
  std::string name;  // [a-z][a-z0-9_]*
  std::string help;
  bool counter = false;
  std::uint64_t value = 0;
};
struct OutputStats {
  std::string instance;
  std::string type;
  bool running = false;
  std::vector<OutputFigure> figures;
};

class PluginHost {
 public:
  static constexpr std::size_t kMaxStats = 16;  // figures read per instance

  // Receives plugin log lines (host->log); must be thread-safe. main wires
  // it to the "gateway" logger; the default writes to stderr.
  using LogSink = std::function<void(LogLevel level, std::string_view instance, std::string_view message)>;
  // Receives host->submit_command (ABI 2) from any plugin thread; returns an
  // enum cobridge_command_status. Must be thread-safe and must not block.
  // Unset: every command is refused with COBRIDGE_COMMAND_UNSUPPORTED.
  // `instance` names the submitting plugin instance (what its writes are
  // recorded as: a configuration drift's writer).
  using CommandSink = std::function<int(std::string_view instance, const cobridge_command& command)>;

  struct Options {
    std::filesystem::path plugin_dir;
    std::string gateway_id;
    LogSink log;
    CommandSink commands{};
    std::uint8_t redundancy_node = 0;  // [redundancy] node_id; 0 = the gateway runs alone
    // Whether a failure the host returns is also logged through `log`. Off
    // for a caller that logs every failure it is returned (the daemon, which
    // adds the configuration's file:line), so each is logged once.
    bool log_failures = true;
  };

  explicit PluginHost(Options options);
  ~PluginHost();  // stop_all, then unload_all
  PluginHost(const PluginHost&) = delete;
  PluginHost& operator=(const PluginHost&) = delete;

  // Loads and creates one instance. On failure nothing is kept and the error
  // is returned (and logged through the sink when log_failures is set).
  [[nodiscard]] Error load(const PluginSpec& spec);
  // Loads every spec; returns the failures, the others stay loaded.
  std::vector<Error> load_all(std::span<const PluginSpec> specs);

  // Starts every loaded, not yet started instance in load order. An
  // instance whose start fails is destroyed and unloaded; its error is
  // returned.
  std::vector<Error> start_all();

  // Dispatcher thread. Hands the batch to every started plugin.
  void deliver(std::span<const Sample> samples) noexcept;
  // Dispatcher thread. Announces a device to every started plugin whose ABI
  // has on_device.
  void announce(const cobridge_device_info& info) noexcept;
  // Dispatcher thread. Tells every started plugin whose ABI has on_role that
  // the gateway's role on a bus changed (hot standby).
  void announce_role(const cobridge_role_info& info) noexcept;
  // Dispatcher thread. Tells every started plugin whose ABI has on_bus
  // (ABI 5) a bus's health.
  void announce_bus(const cobridge_bus_info& info) noexcept;

  // Stops the started instances in reverse load order; they stay loaded and
  // may be started again.
  void stop_all() noexcept;
  // Destroys and unloads every instance in reverse load order (stops first).
  void unload_all() noexcept;

  [[nodiscard]] std::size_t loaded_count() const noexcept { return plugins_.size(); }
  [[nodiscard]] std::size_t started_count() const noexcept;
  // Any thread (status page, /metrics, `cobridge status`): each instance's
  // own figures, in load order; waits while start/stop change the roster.
  [[nodiscard]] std::vector<OutputStats> stats() const;
  // Instance names in load order.
  [[nodiscard]] std::vector<std::string> instances() const;

  // The file a spec resolves to (exposed for error messages and tests).
  [[nodiscard]] std::filesystem::path resolve(const PluginSpec& spec) const;

 private:
  struct Instance;
  static void log_trampoline(void* host, int level, const char* msg) noexcept;
  static int submit_trampoline(void* host, const cobridge_command* command) noexcept;
  void unload(Instance& p) noexcept;
  void report(const std::string& instance, const Error& e) const;
  // The phases of load(); each reports its failure and returns it.
  Error fail(const Instance& p, PluginErrc code, const std::string& reason) const;
  Error open_library(Instance& p, cobridge_plugin_create_fn& create) const;
  Error create_instance(Instance& p, const PluginSpec& spec, cobridge_plugin_create_fn create,
                        const cobridge_plugin_ops*& ops, void*& self) const;
  Error check_ops(const Instance& p, const cobridge_plugin_ops& ops, void* self) const;

  Options options_;
  // unique_ptr: each instance's cobridge_host_api must keep its address, the
  // plugin may hold on to it until destroy.
  std::vector<std::unique_ptr<Instance>> plugins_;
  // Guards the roster (plugins_ and each `started`) against stats() from a
  // control-plane thread; deliver()/announce() on the dispatcher never take
  // it: the roster does not change while the dispatcher runs.
  mutable std::mutex roster_mutex_;
};

}  // namespace cobridge::pipeline

template <>
struct std::is_error_code_enum<cobridge::pipeline::PluginErrc> : std::true_type {};
