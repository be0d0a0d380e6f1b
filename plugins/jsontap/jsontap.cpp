// JSON tap: an output plugin that writes every sample and every device
// announcement as one JSON object per line (JSON Lines) to a file or stdout.
// It is a debugging tap for users ("what does the gateway see?") and the
// witness the plugin tests read back.
//
// Configuration (TOML, the keys of the instance's table):
//   path   = "-"     file to write; "-" = stdout (default)
//   flush  = false   flush after every batch / device line, so that the file
//                    is current at all times (tail -f, tests)
//   append = false   append to an existing file instead of truncating it
//
// Threads: create/start/stop/destroy on the daemon's control thread;
// on_samples/on_device on the dispatcher thread. Lines are formatted with
// std::to_chars into a fixed buffer (no allocation, no locale) and written
// through buffered stdio. A file write may still block on a slow disk or a
// full pipe: this plugin is for debugging, not for production outputs.
#include <cobridge/plugin.h>
#include <cobridge/plugin_error.hpp>

#include "host_log.hpp"

#include <toml++/toml.h>

#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>

namespace cobridge::jsontap {
namespace {

// One output line under construction. Overflow is sticky: the caller drops
// the line and counts it rather than writing broken JSON.
class LineBuffer {
 public:
  void clear() noexcept {
    len_ = 0;
    overflow_ = false;
  }
  [[nodiscard]] bool overflow() const noexcept { return overflow_; }
  [[nodiscard]] std::string_view view() const noexcept { return {buf_.data(), len_}; }

  void raw(std::string_view s) noexcept {
    if (s.size() > buf_.size() - len_) {
      overflow_ = true;
      return;
    }
    std::memcpy(buf_.data() + len_, s.data(), s.size());
    len_ += s.size();
  }
  // Every line opens with {"type":...}, so every key after it takes a comma.
  void key(std::string_view k) noexcept {
    raw(",\"");
    raw(k);
    raw("\":");
  }
  template <typename T>
  void field(std::string_view k, T v) noexcept {
    key(k);
    number(v);
  }
  template <typename T>
  void number(T v) noexcept {
    static_assert(std::is_arithmetic_v<T>);
    char* const first = buf_.data() + len_;
    char* const last = buf_.data() + buf_.size();
    if constexpr (std::is_floating_point_v<T>) {
      if (!std::isfinite(v)) {  // JSON has no NaN/Inf
        raw("null");
        return;
      }
    }
    // For doubles the shortest form that reads back to the same value.
    const auto [end, ec] = std::to_chars(first, last, v);
    if (ec != std::errc{}) {
      overflow_ = true;
      return;
    }
    len_ = static_cast<std::size_t>(end - buf_.data());
  }
  void boolean(bool v) noexcept { raw(v ? "true" : "false"); }
  void hex(const std::uint8_t* bytes, std::size_t n) noexcept {
    static constexpr char kDigits[] = "0123456789abcdef";
    raw("\"");
    for (std::size_t i = 0; i < n; ++i) {
      const char pair[2] = {kDigits[bytes[i] >> 4], kDigits[bytes[i] & 0x0F]};
      raw({pair, 2});
    }
    raw("\"");
  }
  // A JSON string (RFC 8259 §7): quote, backslash and control characters
  // escaped; other bytes (UTF-8) pass through.
  void string(const char* s) noexcept {
    raw("\"");
    for (const char* p = s != nullptr ? s : ""; *p != '\0'; ++p) {
      const auto c = static_cast<unsigned char>(*p);
      if (c == '"' || c == '\\') {
        const char esc[2] = {'\\', static_cast<char>(c)};
        raw({esc, 2});
      } else if (c < 0x20) {
        static constexpr char kDigits[] = "0123456789abcdef";
        const char esc[6] = {'\\', 'u', '0', '0', kDigits[c >> 4], kDigits[c & 0x0F]};
        raw({esc, 6});
      } else {
        const char ch = static_cast<char>(c);
        raw({&ch, 1});
      }
    }
    raw("\"");
  }

 private:
  std::array<char, 4096> buf_{};
  std::size_t len_ = 0;
  bool overflow_ = false;
};

const char* kind_name(std::uint8_t kind) noexcept {
  switch (kind) {
    case COBRIDGE_SAMPLE_TPDO: return "tpdo";
    case COBRIDGE_SAMPLE_EMCY: return "emcy";
    case COBRIDGE_SAMPLE_HEARTBEAT: return "heartbeat";
    case COBRIDGE_SAMPLE_NMT_STATE: return "nmt_state";
    case COBRIDGE_SAMPLE_STATUS: return "status";
    case COBRIDGE_SAMPLE_COMMAND: return "command";
    default: return "unknown";
  }
}

const char* change_name(std::uint8_t change) noexcept {
  switch (change) {
    case COBRIDGE_DEVICE_ADDED: return "added";
    case COBRIDGE_DEVICE_CHANGED: return "changed";
    case COBRIDGE_DEVICE_REMOVED: return "removed";
    default: return "unknown";
  }
}

struct Tap {
  const cobridge_host_api* host = nullptr;
  std::string path = "-";
  bool flush = false;
  bool append = false;
  std::FILE* out = nullptr;
  bool owns_out = false;
  std::unique_ptr<char[]> stdio_buffer;
  LineBuffer line;
  std::uint64_t lines = 0;
  std::uint64_t dropped = 0;  // overflowed or failed writes

  void log(int level, const std::string& msg) const noexcept {
    plugin::host_log(host, level, msg);
  }

  void emit() noexcept {
    if (line.overflow()) {
      ++dropped;
      return;
    }
    line.raw("}\n");
    const std::string_view v = line.view();
    if (!line.overflow() && std::fwrite(v.data(), 1, v.size(), out) == v.size()) {
      ++lines;
    } else {
      ++dropped;
    }
  }

  void write_sample(const cobridge_sample& s) noexcept {
    line.clear();
    line.raw("{\"type\":\"sample\"");
    line.key("kind");
    line.raw("\"");
    line.raw(kind_name(s.kind));
    line.raw("\"");
    line.field("rx_timestamp_ns", s.rx_timestamp_ns);
    line.field("publish_timestamp_ns", s.publish_timestamp_ns);
    line.field("sequence", s.sequence);
    line.field("device_index", s.device_index);
    line.field("bus_index", s.bus_index);
    line.field("node_id", s.node_id);
    line.field("sync_counter", s.sync_counter);
    line.field("cob_id", s.cob_id);
    const unsigned valid = s.valid;
    if ((valid & COBRIDGE_VALID_POSITION) != 0) line.field("position", s.position);
    if ((valid & COBRIDGE_VALID_POSITION_ENG) != 0) line.field("position_eng", s.position_eng);
    if ((valid & COBRIDGE_VALID_SPEED) != 0) line.field("speed", s.speed);
    if ((valid & COBRIDGE_VALID_CAM_STATE) != 0) line.field("cam_state", s.cam_state);
    if ((valid & COBRIDGE_VALID_WORK_AREA_STATE) != 0) {
      line.field("work_area_state", s.work_area_state);
    }
    if ((valid & COBRIDGE_VALID_ALARMS) != 0) line.field("alarms", s.alarms);
    if ((valid & COBRIDGE_VALID_WARNINGS) != 0) line.field("warnings", s.warnings);
    if ((valid & COBRIDGE_VALID_TEMPERATURE) != 0) line.field("temperature_dC", s.temperature_dC);
    if ((valid & COBRIDGE_VALID_VOLTAGE) != 0) line.field("voltage_dV", s.voltage_dV);
    if ((valid & COBRIDGE_VALID_NMT_STATE) != 0) line.field("nmt_state", s.nmt_state);
    if ((valid & COBRIDGE_VALID_STATUS) != 0) {
      line.key("online");
      line.boolean(s.online != 0);
      line.key("stale");
      line.boolean(s.stale != 0);
    }
    if ((valid & COBRIDGE_VALID_EMCY) != 0) {
      line.field("emcy_code", s.emcy_code);
      line.field("emcy_register", s.emcy_register);
      line.key("emcy_data");
      line.hex(s.emcy_data, sizeof s.emcy_data);
    }
    if ((valid & COBRIDGE_VALID_COMMAND) != 0) {
      line.field("command_kind", s.command_kind);
      line.field("command_status", s.command_status);
      line.field("command_tag", s.command_tag);
      line.field("command_abort_code", s.command_abort_code);
    }
    if ((valid & COBRIDGE_VALID_RAW) != 0) {
      const std::size_t n = s.raw_len <= sizeof s.raw ? s.raw_len : sizeof s.raw;
      line.field("raw_len", s.raw_len);
      line.key("raw");
      line.hex(s.raw, n);
    }
    emit();
  }

  void write_device(const cobridge_device_info& d) noexcept {
    line.clear();
    line.raw("{\"type\":\"device\"");
    line.key("change");
    line.raw("\"");
    line.raw(change_name(d.change));
    line.raw("\"");
    line.field("device_index", d.device_index);
    line.field("bus_index", d.bus_index);
    line.field("node_id", d.node_id);
    line.field("vendor_id", d.vendor_id);
    line.field("product_code", d.product_code);
    line.field("revision", d.revision);
    line.field("serial", d.serial);
    line.key("name");
    line.string(d.name);
    line.key("bus_name");
    line.string(d.bus_name);
    line.key("model");
    line.string(d.model);
    line.key("family");
    line.string(d.family);
    line.key("position_unit");
    line.string(d.position_unit);
    emit();
  }
};

using plugin::copy_error;

// Fills `tap` from the TOML text; returns an error message or "".
// The settings; a refusal's message starts "config: ", ready for the err text.
plugin::Error configure(Tap& tap, std::string_view text) {
  using plugin::ConfigErrc;
  const auto refused = [](ConfigErrc code, std::string message) { return plugin::Error(code, "config: " + message); };
  toml::table table;
  try {
    table = toml::parse(text, std::string_view("jsontap"));
  } catch (const toml::parse_error& e) {
    return refused(ConfigErrc::kSyntax,
                   std::string(e.description()) + " at line " + std::to_string(e.source().begin.line));
  }
  plugin::Error error;
  table.for_each([&](const toml::key& key, const auto& value) {
    if (error) return;
    const std::string_view k = key.str();
    if (k == "path") {
      if (const auto* s = value.as_string()) {
        tap.path = s->get();
      } else {
        error = refused(ConfigErrc::kWrongType, "'path' must be a string");
      }
    } else if (k == "flush" || k == "append") {
      if (const auto* b = value.as_boolean()) {
        (k == "flush" ? tap.flush : tap.append) = b->get();
      } else {
        error = refused(ConfigErrc::kWrongType, "'" + std::string(k) + "' must be a boolean");
      }
    } else {
      error = refused(ConfigErrc::kUnknownKey, "unknown key '" + std::string(k) + "' (expected path, flush, append)");
    }
  });
  if (!error && tap.path.empty()) error = refused(ConfigErrc::kOutOfRange, "'path' is empty (use \"-\" for stdout)");
  return error;
}

// --- the ops ---------------------------------------------------------------

int tap_start(void* self) {
  auto* tap = static_cast<Tap*>(self);
  if (tap->path == "-") {
    tap->out = stdout;
    tap->owns_out = false;
  } else {
    tap->out = std::fopen(tap->path.c_str(), tap->append ? "a" : "w");
    if (tap->out == nullptr) {
      tap->log(COBRIDGE_LOG_ERROR, "cannot open " + tap->path + ": " + std::strerror(errno));
      return -1;
    }
    tap->owns_out = true;
    // A bigger buffer than BUFSIZ: fewer write() calls on the dispatcher thread.
    constexpr std::size_t kBuffer = 64 * 1024;
    tap->stdio_buffer.reset(new (std::nothrow) char[kBuffer]);
    if (tap->stdio_buffer) std::setvbuf(tap->out, tap->stdio_buffer.get(), _IOFBF, kBuffer);
  }
  tap->lines = 0;
  tap->dropped = 0;
  return 0;
}

void tap_stop(void* self) {
  auto* tap = static_cast<Tap*>(self);
  if (tap->out == nullptr) return;
  std::fflush(tap->out);
  if (tap->owns_out) std::fclose(tap->out);
  tap->out = nullptr;
  tap->stdio_buffer.reset();
  if (tap->dropped != 0) {
    tap->log(COBRIDGE_LOG_WARN, "wrote " + std::to_string(tap->lines) + " lines, dropped " +
                                    std::to_string(tap->dropped) + " (too long or write error)");
  }
}

void tap_destroy(void* self) {
  auto* tap = static_cast<Tap*>(self);
  tap_stop(tap);
  delete tap;
}

void tap_on_samples(void* self, const cobridge_sample* samples, std::size_t count) {
  auto* tap = static_cast<Tap*>(self);
  if (tap->out == nullptr) return;
  for (std::size_t i = 0; i < count; ++i) tap->write_sample(samples[i]);
  if (tap->flush) std::fflush(tap->out);
}

void tap_on_device(void* self, const cobridge_device_info* info) {
  auto* tap = static_cast<Tap*>(self);
  // Strings were added with the first version, but a struct_size check keeps
  // this correct if the host ever hands an older, shorter layout.
  if (tap->out == nullptr || info == nullptr ||
      info->struct_size < offsetof(cobridge_device_info, position_unit) + sizeof(const char*)) {
    return;
  }
  tap->write_device(*info);
  if (tap->flush) std::fflush(tap->out);
}

constexpr cobridge_plugin_ops kOps = {
    COBRIDGE_PLUGIN_ABI_VERSION,
    sizeof(cobridge_plugin_ops),
    "jsontap",
    &tap_start,
    &tap_stop,
    &tap_destroy,
    &tap_on_samples,
    &tap_on_device,
    nullptr,  // stats: the tap reports nothing of its own
    nullptr,  // on_role: both gateways of a pair tap the same frames
    nullptr,  // on_bus: the tap prints samples only
};

}  // namespace
}  // namespace cobridge::jsontap

extern "C" COBRIDGE_PLUGIN_EXPORT int cobridge_plugin_create(const cobridge_host_api* host, const char* config_toml,
                                                             size_t config_len, const cobridge_plugin_ops** ops_out,
                                                             void** self_out, char* err, size_t err_len) {
  using namespace cobridge::jsontap;
  return cobridge::plugin::create_plugin(
      "jsontap", &kOps, host, config_toml, config_len, ops_out, self_out, err, err_len,
      [host](std::string_view config, cobridge::plugin::Error& error) -> void* {
        auto tap = std::make_unique<Tap>();
        tap->host = host;
        error = configure(*tap, config);
        return error ? nullptr : tap.release();
      });
}
