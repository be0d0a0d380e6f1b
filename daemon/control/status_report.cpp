#include "control/status_report.hpp"

#include "base/error.hpp"
#include "base/json_writer.hpp"
#include "canopen/nmt.hpp"
#include "bus/config_drift.hpp"

#include <array>
#include <cstdio>
#include <ctime>

namespace cobridge::control {
namespace {

// ISO 8601 UTC to the millisecond; the zero time (never) is null.
void write_time(JsonWriter& w, bus::WallTime t) {
  if (t == bus::WallTime{}) {
    w.null();
    return;
  }
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(t.time_since_epoch()).count();
  const std::time_t secs = static_cast<std::time_t>(ms / 1000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  std::array<char, 96> buf{};  // room for any int, so -O2's truncation check is satisfied
  std::snprintf(buf.data(), buf.size(), "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900, tm.tm_mon + 1,
                tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, static_cast<int>(ms % 1000));
  w.value(std::string_view(buf.data()));
}

void write_identity(JsonWriter& w, const bus::DeviceStatus& d) {
  w.key("identity");
  w.begin_object();
  w.field("vendor", std::uint64_t{d.identity.vendor});
  w.field("product", std::uint64_t{d.identity.product});
  w.field("revision", std::uint64_t{d.identity.revision});
  w.field("serial", std::uint64_t{d.identity.serial});
  w.end_object();
}

// The last EMCY (null when there has been none) and the recent ones.
void write_emcy(JsonWriter& w, const bus::DeviceStatus& d) {
  w.key("last_emcy");
  if (d.emcy_count == 0 && d.last_emcy_code == 0 && d.last_emcy_text.empty()) {
    w.null();
  } else {
    w.begin_object();
    w.field("code", std::uint64_t{d.last_emcy_code});
    w.field("text", d.last_emcy_text);
    w.end_object();
  }
}

void write_emcy_history(JsonWriter& w, const bus::DeviceStatus& d) {
  w.key("emcy_history");
  w.begin_array();
  for (const auto& e : d.emcy_history) {
    w.begin_object();
    w.field("code", std::uint64_t{e.code});
    w.field("text", e.text);
    w.key("at");
    write_time(w, e.at);
    w.end_object();
  }
  w.end_array();
}

// The device's timeline (bus/device_timeline.hpp), oldest first: what
// `cobridge why` and the page's timeline read.
void write_timeline(JsonWriter& w, const bus::DeviceStatus& d) {
  w.key("timeline");
  w.begin_array();
  for (const auto& e : d.timeline) {
    w.begin_object();
    w.key("at");
    write_time(w, e.at);
    w.field("kind", to_string(e.kind));
    w.field("text", e.text);
    w.key("capture");
    if (e.capture.empty()) w.null(); else w.value(e.capture);
    w.field("repeats", std::uint64_t{e.repeats});
    w.key("last_at");
    write_time(w, e.last_at);
    w.end_object();
  }
  w.end_array();
}

// The objects a client set away from the configuration; the contested ones
// the gateway no longer writes back (bus/restore_guard.hpp).
void write_drift(JsonWriter& w, const bus::DeviceStatus& d) {
  w.field("config_differs", !d.drift.empty());
  w.field("config_contested", bus::contested_count(d) > 0);
  w.key("drift");
  w.begin_array();
  for (const auto& r : d.drift) {
    w.begin_object();
    w.field("object", r.object);
    w.field("name", r.name);
    w.field("configured", std::uint64_t{r.configured});
    w.field("value", std::uint64_t{r.value});
    w.field("writer", r.writer);
    w.key("at");
    write_time(w, r.at);
    w.field("text", bus::drift_text(r));
    w.field("restores", std::uint64_t{r.restores});
    w.field("contested", r.contested);
    w.end_object();
  }
  w.end_array();
}

// The latest values (null before the first) and the heartbeat's age.
void write_values(JsonWriter& w, const bus::LiveValues& v) {
  w.key("values");
  if (!v.present) {
    w.null();
  } else {
    w.begin_object();
    if (v.has_position) {
      w.field("position", static_cast<std::int64_t>(v.position));
      w.field("position_eng", v.position_eng);
      w.field("unit", v.unit);
    }
    if (v.has_speed) w.field("speed", static_cast<std::int64_t>(v.speed));
    w.field("age_s", v.age_s);
    w.key("at");
    write_time(w, v.at);
    w.field("stale", v.stale);
    w.end_object();
  }
  w.key("heartbeat_age_s");
  if (v.heartbeat_age_s < 0)
    w.null();
  else
    w.value(v.heartbeat_age_s);
}

void write_device(JsonWriter& w, const bus::DeviceStatus& d) {
  w.begin_object();
  w.field("name", d.name);
  w.field("bus", d.bus);
  w.key("node_id");
  if (d.node_id == 0)
    w.null();
  else
    w.value(std::uint64_t{d.node_id});
  write_identity(w, d);
  w.field("model", d.model);
  w.field("family", d.family);
  w.field("state", to_string(d.state));
  w.field("nmt", canopen::to_string(d.nmt));
  w.field("online", d.online);
  w.key("since");
  write_time(w, d.since);
  w.field("last_error", d.last_error);
  write_emcy(w, d);
  w.field("boot_ups", std::uint64_t{d.boot_ups});
  w.field("configurations", std::uint64_t{d.configurations});
  w.field("emcy_count", std::uint64_t{d.emcy_count});
  w.field("fingerprint", d.fingerprint);
  w.field("commission_failures", std::uint64_t{d.commission_failures});
  w.key("next_retry");
  write_time(w, d.next_retry);
  write_emcy_history(w, d);
  write_timeline(w, d);
  write_drift(w, d);
  write_values(w, d.values);
  w.end_object();
}

// [redundancy]: the role of this gateway on the bus and why.
void write_redundancy(JsonWriter& w, const bus::BusStatus& b) {
  w.key("redundancy");
  w.begin_object();
  w.field("role", b.role);
  w.field("master_node", std::uint64_t{b.master_node});
  w.field("peer_node", std::uint64_t{b.peer_node});
  w.field("cause", b.election_cause);
  w.key("since");
  write_time(w, b.election_at);
  w.end_object();
}

// The CAN controller's fault confinement state and counters (error frames,
// netlink), where they came from, and whether the driver reports a state
// at all (vcan does not: then "unknown" until error frames tell one).
void write_controller(JsonWriter& w, const can::ControllerHealth& c) {
  w.key("controller");
  w.begin_object();
  w.field("state", std::string(can::to_string(c.state)));
  w.field("source", std::string(can::to_string(c.source)));
  w.key("driver_reports_state");
  if (c.driver == can::DriverReport::state) w.value(true);
  else if (c.driver == can::DriverReport::no_state) w.value(false);
  else w.null();
  w.key("tx_errors");
  if (c.counters_known) w.value(std::uint64_t{c.tx_errors}); else w.null();
  w.key("rx_errors");
  if (c.counters_known) w.value(std::uint64_t{c.rx_errors}); else w.null();
  w.field("restarts", c.restarts);
  w.field("bus_errors", c.bus_errors);
  w.end_object();
}

void write_strings(JsonWriter& w, std::string_view key, const std::vector<std::string>& items) {
  w.key(key);
  w.begin_array();
  for (const auto& s : items) w.value(s);
  w.end_array();
}

// The flight recorder: its ring and the captures on disk (null when off).
void write_recorder(JsonWriter& w, const bus::RecorderStatus& r) {
  w.key("recorder");
  if (!r.on) {
    w.null();
    return;
  }
  w.begin_object();
  w.field("seconds", std::uint64_t{r.seconds});
  w.field("capacity_frames", std::uint64_t{r.capacity});
  w.field("memory_bytes", r.memory_bytes);
  w.field("recorded_frames", r.recorded);
  w.field("pending_captures", std::uint64_t{r.pending});
  w.field("budget_per_hour", std::uint64_t{r.budget_per_hour});
  w.field("skipped_over_budget", r.skipped_over_budget);
  w.field("dir", r.dir);
  w.key("captures");
  w.begin_array();
  for (const auto& c : r.captures) {
    w.begin_object();
    w.field("name", c.name);
    write_strings(w, "causes", c.causes);
    write_strings(w, "devices", c.devices);
    w.key("at");
    write_time(w, c.fault_ns == 0 ? bus::WallTime{} : bus::WallTime{std::chrono::duration_cast<bus::WallTime::duration>(std::chrono::nanoseconds(c.fault_ns))});
    w.field("frames", std::uint64_t{c.frames});
    w.field("bytes", c.bytes);
    w.end_object();
  }
  w.end_array();
  w.end_object();
}

void write_bus(JsonWriter& w, const bus::BusStatus& b) {
  w.begin_object();
  w.field("name", b.name);
  w.field("interface", b.interface);
  w.field("open", b.open);
  w.field("bitrate_kbit", std::uint64_t{b.bitrate_kbit});
  w.field("last_bus_event", b.last_bus_event);
  if (!b.role.empty()) write_redundancy(w, b);
  write_controller(w, b.controller);
  write_recorder(w, b.recorder);
  w.key("counters");
  w.begin_object();
  w.field("rx_frames", b.rx_frames);
  w.field("tx_frames", b.tx_frames);
  w.field("rx_overflow_drops", b.rx_overflow_drops);
  w.field("error_frames", b.error_frames);
  w.field("reopens", std::uint64_t{b.reopens});
  w.field("unknown_node_frames", b.unknown_node_frames);
  w.field("ring_drops", b.ring_drops);
  w.field("hot_rx_frames", b.hot_rx_frames);
  w.field("hot_kernel_drops", b.hot_kernel_drops);
  w.field("status_drops", b.status_drops);
  w.field("bad_length_frames", b.bad_length_frames);
  w.field("tx_dropped", b.tx_dropped);
  w.end_object();
  w.key("devices");
  w.begin_array();
  for (const auto& d : b.devices) write_device(w, d);
  w.end_array();
  w.key("steps");
  w.begin_array();
  for (const auto& s : b.steps) {
    w.begin_object();
    w.field("step", s.step);
    w.field("device", s.device);
    w.field("ms", s.milliseconds);
    if (s.exchanges != 0) {
      w.field("exchanges", std::uint64_t{s.exchanges});
      w.field("timeouts", std::uint64_t{s.timeouts});
      w.field("restarts", std::uint64_t{s.restarts});
    }
    w.key("at");
    write_time(w, s.at);
    w.end_object();
  }
  w.end_array();
  w.key("problems");
  w.begin_array();
  for (const auto& p : b.problems) w.value(p);
  w.end_array();
  w.end_object();
}

// What each output plugin reports of itself (ABI 3 stats): Modbus clients
// connected, DDS writers, ...
void write_outputs(JsonWriter& w, const std::vector<pipeline::OutputStats>& outputs) {
  w.begin_array();
  for (const auto& o : outputs) {
    w.begin_object();
    w.field("instance", o.instance);
    w.field("type", o.type);
    w.field("running", o.running);
    w.key("figures");
    w.begin_object();
    for (const auto& f : o.figures) w.field(f.name, f.value);
    w.end_object();
    w.end_object();
  }
  w.end_array();
}

}  // namespace

std::string to_json(const StatusReport& report) {
  JsonWriter w;
  w.begin_object();
  w.field("gateway", report.gateway_id);
  w.field("version", report.version);
  w.field("pid", static_cast<std::int64_t>(report.pid));
  w.field("ready", report.ready);
  w.key("started");
  write_time(w, report.started);
  w.field("config", report.config_file);
  std::uint64_t total = 0;
  std::uint64_t operational = 0;
  for (const auto& b : report.buses) {
    for (const auto& d : b.devices) {
      ++total;
      if (d.state == bus::DeviceState::operational) ++operational;
    }
  }
  w.field("devices_total", total);
  w.field("devices_operational", operational);
  w.key("buses");
  w.begin_array();
  for (const auto& b : report.buses) write_bus(w, b);
  w.end_array();
  w.key("outputs");
  write_outputs(w, report.outputs);
  w.end_object();
  return w.take();
}

std::string summary(const std::vector<bus::BusStatus>& buses) {
  std::size_t total = 0;
  std::size_t operational = 0;
  std::size_t open = 0;
  std::string closed;
  for (const auto& b : buses) {
    if (b.open) ++open;
    if (!b.open) closed += (closed.empty() ? "" : ", ") + b.name + " (" + b.interface + ")";
    for (const auto& d : b.devices) {
      ++total;
      if (d.state == bus::DeviceState::operational) ++operational;
    }
  }
  std::string s = std::to_string(buses.size()) + (buses.size() == 1 ? " bus" : " buses");
  if (open != buses.size()) s += " (" + std::to_string(open) + " open; waiting for " + closed + ")";
  s += ", " + std::to_string(operational) + "/" + std::to_string(total) + " devices operational";
  return s;
}

}  // namespace cobridge::control
