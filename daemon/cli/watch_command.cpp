#include "cli/watch_command.hpp"

#include "base/error.hpp"
#include "base/number_text.hpp"

#include "cobridge_idl/cobridge.h"

#include <dds/dds.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace cobridge::cli {
namespace {

std::atomic<bool> g_interrupted{false};
extern "C" void on_signal(int) { g_interrupted.store(true); }

// RAII for the participant: deleting it deletes every reader and condition.
struct Participant {
  dds_entity_t id = 0;
  ~Participant() {
    if (id > 0) (void)dds_delete(id);
  }
};

// A JSON string (RFC 8259 §7).
void json_string(std::string& out, const char* s) { out += json_quote(s != nullptr ? s : ""); }

template <typename T>
void json_field(std::string& out, const char* key, T value) {
  out += ",\"";
  out += key;
  out += "\":";
  if constexpr (std::is_same_v<T, bool>) {
    out += value ? "true" : "false";
  } else if constexpr (std::is_same_v<T, const char*> || std::is_same_v<T, char*>) {
    json_string(out, value);
  } else {
    out += std::to_string(value);
  }
}

void json_double(std::string& out, const char* key, double value) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", value);
  out += ",\"";
  out += key;
  out += "\":";
  out += buf;
}

// HH:MM:SS.uuuuuu local time of a Unix-epoch ns stamp.
std::string clock_text(std::uint64_t ns) {
  const auto secs = static_cast<std::time_t>(ns / 1000000000u);
  std::tm tm{};
  localtime_r(&secs, &tm);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%02d:%02d:%02d.%06u", tm.tm_hour, tm.tm_min, tm.tm_sec,
                static_cast<unsigned>((ns % 1000000000u) / 1000u));
  return buf;
}

std::string who(const char* gw, unsigned bus, unsigned node, const char* name) {
  std::string s = gw != nullptr ? gw : "";
  s += '/' + std::to_string(bus) + '/' + std::to_string(node);
  if (name != nullptr && *name != '\0') {
    s += ' ';
    s += name;
  }
  return s;
}

const char* nmt_text(unsigned state) {
  switch (state) {
    case cobridge_NMT_BOOT_UP: return "boot-up";
    case cobridge_NMT_STOPPED: return "stopped";
    case cobridge_NMT_OPERATIONAL: return "operational";
    case cobridge_NMT_PRE_OPERATIONAL: return "pre-operational";
    default: return "unknown";
  }
}

std::string format_sample(const cobridge_EncoderSample& s, bool json) {
  std::string out;
  const unsigned v = s.valid;
  if (json) {
    out = "{\"topic\":\"EncoderSample\"";
    json_field(out, "gateway_id", s.gateway_id);
    json_field(out, "bus", s.bus);
    json_field(out, "node_id", s.node_id);
    json_field(out, "device_name", s.device_name);
    if ((v & cobridge_VALID_POSITION) != 0) json_field(out, "position", s.position);
    if ((v & cobridge_VALID_POSITION_ENG) != 0) json_double(out, "position_eng", s.position_eng);
    if ((v & cobridge_VALID_SPEED) != 0) json_field(out, "speed", s.speed);
    if ((v & cobridge_VALID_CAM_STATE) != 0) json_field(out, "cam_state", s.cam_state);
    if ((v & cobridge_VALID_WORK_AREA_STATE) != 0) json_field(out, "work_area_state", s.work_area_state);
    if ((v & cobridge_VALID_ALARMS) != 0) json_field(out, "alarms", s.alarms);
    if ((v & cobridge_VALID_WARNINGS) != 0) json_field(out, "warnings", s.warnings);
    if ((v & cobridge_VALID_TEMPERATURE) != 0) json_field(out, "temperature_dC", s.temperature_dC);
    if ((v & cobridge_VALID_VOLTAGE) != 0) json_field(out, "voltage_dV", s.voltage_dV);
    json_field(out, "valid", s.valid);
    json_field(out, "rx_timestamp_ns", s.rx_timestamp_ns);
    json_field(out, "publish_timestamp_ns", s.publish_timestamp_ns);
    json_field(out, "sequence", s.sequence_number);
    json_field(out, "sync_counter", s.sync_counter);
    json_field(out, "stale", s.stale);
    out += '}';
    return out;
  }
  out = clock_text(s.rx_timestamp_ns) + "  " + who(s.gateway_id, s.bus, s.node_id, s.device_name) + "  ";
  if ((v & cobridge_VALID_POSITION) != 0) out += "pos=" + std::to_string(s.position) + ' ';
  if ((v & cobridge_VALID_POSITION_ENG) != 0) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "(%.4g) ", s.position_eng);
    out += buf;
  }
  if ((v & cobridge_VALID_SPEED) != 0) out += "speed=" + std::to_string(s.speed) + ' ';
  if ((v & cobridge_VALID_CAM_STATE) != 0) out += "cam=" + hex(s.cam_state, 2) + ' ';
  if ((v & cobridge_VALID_WORK_AREA_STATE) != 0) out += "area=" + hex(s.work_area_state, 2) + ' ';
  if ((v & cobridge_VALID_ALARMS) != 0) out += "alarms=" + hex(s.alarms, 4) + ' ';
  if ((v & cobridge_VALID_WARNINGS) != 0) out += "warnings=" + hex(s.warnings, 4) + ' ';
  if ((v & cobridge_VALID_TEMPERATURE) != 0) out += "temp=" + std::to_string(s.temperature_dC / 10.0).substr(0, 5) + "C ";
  if ((v & cobridge_VALID_VOLTAGE) != 0) out += "supply=" + std::to_string(s.voltage_dV / 10.0).substr(0, 5) + "V ";
  out += "seq=" + std::to_string(s.sequence_number);
  if (s.stale) out += "  STALE";
  return out;
}

std::string format_event(const cobridge_EncoderEvent& e, bool json) {
  std::string data;
  for (const std::uint8_t b : e.data) {
    char buf[4];
    std::snprintf(buf, sizeof buf, "%02x", b);
    data += buf;
  }
  if (json) {
    std::string out = "{\"topic\":\"EncoderEvent\"";
    json_field(out, "gateway_id", e.gateway_id);
    json_field(out, "bus", e.bus);
    json_field(out, "node_id", e.node_id);
    json_field(out, "device_name", e.device_name);
    json_field(out, "code", e.code);
    json_field(out, "error_register", e.error_register);
    json_field(out, "data", data.c_str());
    json_field(out, "text", e.text);
    json_field(out, "source", e.source);
    json_field(out, "error_reset", e.error_reset);
    json_field(out, "rx_timestamp_ns", e.rx_timestamp_ns);
    json_field(out, "sequence", e.sequence_number);
    out += '}';
    return out;
  }
  return clock_text(e.rx_timestamp_ns) + "  " + who(e.gateway_id, e.bus, e.node_id, e.device_name) + "  EVENT " +
         hex(e.code, 4) + " reg=" + hex(e.error_register, 2) + " data=" + data + " \"" + (e.text ? e.text : "") +
         "\" (" + (e.source ? e.source : "") + ")" + (e.error_reset ? " reset" : "") +
         " seq=" + std::to_string(e.sequence_number);
}

std::string format_status(const cobridge_DeviceStatus& s, bool disposed, bool json) {
  if (json) {
    std::string out = "{\"topic\":\"DeviceStatus\"";
    json_field(out, "gateway_id", s.gateway_id);
    json_field(out, "bus", s.bus);
    json_field(out, "node_id", s.node_id);
    if (disposed) {
      json_field(out, "removed", true);
      out += '}';
      return out;
    }
    json_field(out, "name", s.name);
    json_field(out, "bus_name", s.bus_name);
    json_field(out, "vendor_id", s.vendor_id);
    json_field(out, "product_code", s.product_code);
    json_field(out, "revision", s.revision);
    json_field(out, "serial", s.serial);
    json_field(out, "model", s.model);
    json_field(out, "family", s.family);
    json_field(out, "position_unit", s.position_unit);
    json_field(out, "nmt_state", s.nmt_state);
    json_field(out, "online", s.online);
    json_field(out, "stale", s.stale);
    json_field(out, "last_emcy_code", s.last_emcy_code);
    json_field(out, "last_emcy_register", s.last_emcy_register);
    json_field(out, "last_emcy_ns", s.last_emcy_ns);
    json_field(out, "updated_ns", s.updated_ns);
    json_field(out, "config_state", s.config_state);
    out += '}';
    return out;
  }
  const auto now = static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count());
  if (disposed) return clock_text(now) + "  " + who(s.gateway_id, s.bus, s.node_id, nullptr) + "  STATUS removed";
  std::string out = clock_text(s.updated_ns != 0 ? s.updated_ns : now) + "  " +
                    who(s.gateway_id, s.bus, s.node_id, s.name) + "  STATUS " + (s.online ? "online" : "OFFLINE") +
                    " nmt=" + nmt_text(s.nmt_state);
  if (s.stale) out += " STALE";
  if (s.config_state == cobridge_CONFIG_DIFFERS) out += " CONFIG-DIFFERS";
  if (s.config_state == cobridge_CONFIG_CONTESTED) out += " CONFIG-CONTESTED";
  if (s.last_emcy_ns != 0) out += " last-emcy=" + hex(s.last_emcy_code, 4);
  if (s.model != nullptr && *s.model != '\0') out += std::string(" model=") + s.model;
  char id[64];
  std::snprintf(id, sizeof id, " id=%08x:%08x:%08x:%u", s.vendor_id, s.product_code, s.revision, s.serial);
  out += id;
  return out;
}

dds_qos_t* reader_qos(dds_reliability_kind_t reliability, dds_durability_kind_t durability, int32_t depth) {
  dds_qos_t* q = dds_create_qos();
  dds_qset_reliability(q, reliability, DDS_MSECS(100));
  dds_qset_durability(q, durability);
  if (depth > 0)
    dds_qset_history(q, DDS_HISTORY_KEEP_LAST, depth);
  else
    dds_qset_history(q, DDS_HISTORY_KEEP_ALL, 0);
  return q;
}

struct WatchReader {
  const char* topic;
  const dds_topic_descriptor_t* type;
  dds_qos_t* qos;
  dds_entity_t reader = 0;
};

// Creates each reader with its topic and attaches it to the wait set; the
// QoS objects are deleted either way. Returns 0, or 1 when one failed.
int subscribe(dds_entity_t participant, dds_entity_t ws, const std::string& topic_prefix,
              std::span<WatchReader> readers) {
  int rc = 0;
  for (WatchReader& r : readers) {
    const std::string name = topic_prefix + r.topic;
    const dds_entity_t topic = dds_create_topic(participant, r.type, name.c_str(), nullptr, nullptr);
    if (topic >= 0) r.reader = dds_create_reader(participant, topic, r.qos, nullptr);
    dds_delete_qos(r.qos);
    if (topic < 0 || r.reader < 0) {
      std::fprintf(stderr, "watch: cannot subscribe to %s: %s\n", name.c_str(),
                   dds_strretcode(topic < 0 ? topic : r.reader));
      rc = 1;
      continue;
    }
    const dds_entity_t cond = dds_create_readcondition(r.reader, DDS_ANY_STATE);
    (void)dds_waitset_attach(ws, cond, r.reader);
  }
  return rc;
}

// Prints the lines of the wanted gateway until --count is reached.
struct LinePrinter {
  const WatchOptions& o;
  std::uint64_t printed = 0;

  [[nodiscard]] bool done() const { return o.count != 0 && printed >= o.count; }
  [[nodiscard]] bool wanted(const char* gw) const {
    return o.gateway.empty() || o.gateway == (gw != nullptr ? gw : "");
  }
  void print(const std::string& line) {
    if (done()) return;
    std::fputs(line.c_str(), stdout);
    std::fputc('\n', stdout);
    ++printed;
  }
};

// Prints one taken sample of reader r.
void print_sample(const WatchReader& r, const void* sample, const dds_sample_info_t& info, LinePrinter& out) {
  const bool json = out.o.json;
  if (r.type == &cobridge_EncoderSample_desc) {
    const auto* s = static_cast<const cobridge_EncoderSample*>(sample);
    if (info.valid_data && out.wanted(s->gateway_id)) out.print(format_sample(*s, json));
  } else if (r.type == &cobridge_EncoderEvent_desc) {
    const auto* e = static_cast<const cobridge_EncoderEvent*>(sample);
    if (info.valid_data && out.wanted(e->gateway_id)) out.print(format_event(*e, json));
  } else {
    // An invalid sample of a disposed instance still carries its key.
    const auto* s = static_cast<const cobridge_DeviceStatus*>(sample);
    if (out.wanted(s->gateway_id)) out.print(format_status(*s, !info.valid_data, json));
  }
}

// Takes and prints everything reader r holds.
void drain(const WatchReader& r, LinePrinter& out) {
  constexpr std::size_t kMax = 64;
  void* buf[kMax];
  dds_sample_info_t info[kMax];
  for (;;) {
    buf[0] = nullptr;
    const int n = dds_take(r.reader, buf, info, kMax, kMax);
    if (n <= 0) break;
    for (int i = 0; i < n; ++i) {
      const auto idx = static_cast<std::size_t>(i);
      const bool disposed = info[idx].instance_state == DDS_IST_NOT_ALIVE_DISPOSED;
      if (!info[idx].valid_data && !disposed) continue;
      print_sample(r, buf[idx], info[idx], out);
    }
    (void)dds_return_loan(r.reader, buf, n);
  }
}

// How long the next wait may take: 200 ms, less near --timeout; none when
// the timeout has passed.
std::optional<dds_duration_t> next_slice(const WatchOptions& o, std::chrono::steady_clock::time_point start) {
  dds_duration_t slice = DDS_MSECS(200);
  if (o.timeout_s > 0) {
    const double left = o.timeout_s - std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (left <= 0) return std::nullopt;
    if (left < 0.2) slice = static_cast<dds_duration_t>(left * 1e9);
  }
  return slice;
}

}  // namespace

int watch(const WatchOptions& o) {
  Participant pp;
  pp.id = dds_create_participant(static_cast<dds_domainid_t>(o.domain), nullptr, nullptr);
  if (pp.id < 0) {
    std::fprintf(stderr, "watch: cannot join DDS domain %u: %s\n", o.domain, dds_strretcode(pp.id));
    return 1;
  }
  WatchReader readers[] = {
      {"DeviceStatus", &cobridge_DeviceStatus_desc,
       reader_qos(DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL, 1)},
      {"EncoderEvent", &cobridge_EncoderEvent_desc, reader_qos(DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_VOLATILE, 32)},
      {"EncoderSample", &cobridge_EncoderSample_desc,
       o.reliable ? reader_qos(DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_VOLATILE, 0)
                  : reader_qos(DDS_RELIABILITY_BEST_EFFORT, DDS_DURABILITY_VOLATILE, 16)},
  };
  const dds_entity_t ws = dds_create_waitset(pp.id);
  if (const int rc = subscribe(pp.id, ws, o.topic_prefix, readers); rc != 0) return rc;

  g_interrupted.store(false);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  const auto start = std::chrono::steady_clock::now();
  LinePrinter out{o};
  while (!out.done() && !g_interrupted.load()) {
    const std::optional<dds_duration_t> slice = next_slice(o, start);
    if (!slice) break;
    dds_attach_t triggered[3];
    if (dds_waitset_wait(ws, triggered, 3, *slice) < 0) break;
    // Status first, so a device's name and state precede its values.
    for (const WatchReader& r : readers) drain(r, out);
    std::fflush(stdout);
  }
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  if (o.count != 0 && out.printed < o.count && !g_interrupted.load()) {
    std::fprintf(stderr, "watch: timeout after %llu of %llu samples\n", static_cast<unsigned long long>(out.printed),
                 static_cast<unsigned long long>(o.count));
    return 3;
  }
  return 0;
}

}  // namespace cobridge::cli
