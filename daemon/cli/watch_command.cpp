#include "cli/watch_command.hpp"

#include "base/error.hpp"
#include "base/json_writer.hpp"
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

std::string sample_json(const cobridge_EncoderSample& s) {
  const unsigned v = s.valid;
  JsonWriter w;
  w.begin_object().field("topic", "EncoderSample").field("gateway_id", s.gateway_id).field("bus", s.bus);
  w.field("node_id", s.node_id).field("device_name", s.device_name);
  if ((v & cobridge_VALID_POSITION) != 0) w.field("position", s.position);
  if ((v & cobridge_VALID_POSITION_ENG) != 0) w.key("position_eng").exact(s.position_eng);
  if ((v & cobridge_VALID_SPEED) != 0) w.field("speed", s.speed);
  if ((v & cobridge_VALID_CAM_STATE) != 0) w.field("cam_state", s.cam_state);
  if ((v & cobridge_VALID_WORK_AREA_STATE) != 0) w.field("work_area_state", s.work_area_state);
  if ((v & cobridge_VALID_ALARMS) != 0) w.field("alarms", s.alarms);
  if ((v & cobridge_VALID_WARNINGS) != 0) w.field("warnings", s.warnings);
  if ((v & cobridge_VALID_TEMPERATURE) != 0) w.field("temperature_dC", s.temperature_dC);
  if ((v & cobridge_VALID_VOLTAGE) != 0) w.field("voltage_dV", s.voltage_dV);
  w.field("valid", s.valid).field("rx_timestamp_ns", s.rx_timestamp_ns);
  w.field("publish_timestamp_ns", s.publish_timestamp_ns).field("sequence", s.sequence_number);
  w.field("sync_counter", s.sync_counter).field("stale", s.stale);
  return w.end_object().take();
}

std::string format_sample(const cobridge_EncoderSample& s, bool json) {
  if (json) return sample_json(s);
  const unsigned v = s.valid;
  std::string out = clock_text(s.rx_timestamp_ns) + "  " + who(s.gateway_id, s.bus, s.node_id, s.device_name) + "  ";
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
    JsonWriter w;
    w.begin_object().field("topic", "EncoderEvent").field("gateway_id", e.gateway_id).field("bus", e.bus);
    w.field("node_id", e.node_id).field("device_name", e.device_name).field("code", e.code);
    w.field("error_register", e.error_register).field("data", data).field("text", e.text);
    w.field("source", e.source).field("error_reset", e.error_reset).field("rx_timestamp_ns", e.rx_timestamp_ns);
    w.field("sequence", e.sequence_number);
    return w.end_object().take();
  }
  return clock_text(e.rx_timestamp_ns) + "  " + who(e.gateway_id, e.bus, e.node_id, e.device_name) + "  EVENT " +
         hex(e.code, 4) + " reg=" + hex(e.error_register, 2) + " data=" + data + " \"" + (e.text ? e.text : "") +
         "\" (" + (e.source ? e.source : "") + ")" + (e.error_reset ? " reset" : "") +
         " seq=" + std::to_string(e.sequence_number);
}

std::string status_json(const cobridge_DeviceStatus& s, bool disposed) {
  JsonWriter w;
  w.begin_object().field("topic", "DeviceStatus").field("gateway_id", s.gateway_id).field("bus", s.bus);
  w.field("node_id", s.node_id);
  if (disposed) return w.field("removed", true).end_object().take();
  w.field("name", s.name).field("bus_name", s.bus_name).field("vendor_id", s.vendor_id);
  w.field("product_code", s.product_code).field("revision", s.revision).field("serial", s.serial);
  w.field("model", s.model).field("family", s.family).field("position_unit", s.position_unit);
  w.field("nmt_state", s.nmt_state).field("online", s.online).field("stale", s.stale);
  w.field("last_emcy_code", s.last_emcy_code).field("last_emcy_register", s.last_emcy_register);
  w.field("last_emcy_ns", s.last_emcy_ns).field("updated_ns", s.updated_ns).field("config_state", s.config_state);
  return w.end_object().take();
}

std::string format_status(const cobridge_DeviceStatus& s, bool disposed, bool json) {
  if (json) return status_json(s, disposed);
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
