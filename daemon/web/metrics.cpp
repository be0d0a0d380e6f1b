#include "web/metrics.hpp"

#include <array>
#include <chrono>
#include <cstdio>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace cobridge::web {
namespace {

using bus::BusStatus;
using bus::DeviceState;
using bus::DeviceStatus;

constexpr std::array kStates{DeviceState::expected,    DeviceState::identified, DeviceState::commissioning,
                             DeviceState::configuring, DeviceState::operational, DeviceState::offline,
                             DeviceState::failed,      DeviceState::stopped};

// A label value: backslash, double quote and line feed escaped (the format's rule).
void label_value(std::string& out, std::string_view v) {
  out += '"';
  for (const char c : v) {
    if (c == '\\') out += "\\\\";
    else if (c == '"') out += "\\\"";
    else if (c == '\n') out += "\\n";
    else out += c;
  }
  out += '"';
}

void number(std::string& out, double v) {
  std::array<char, 32> buf{};
  std::snprintf(buf.data(), buf.size(), "%.6g", v);
  out += buf.data();
}

class Writer {
 public:
  void family(std::string_view name, std::string_view type, std::string_view help) {
    name_ = name;
    out_ += "# HELP ";
    out_ += name;
    out_ += ' ';
    out_ += help;
    out_ += "\n# TYPE ";
    out_ += name;
    out_ += ' ';
    out_ += type;
    out_ += '\n';
  }
  using Labels = std::initializer_list<std::pair<std::string_view, std::string_view>>;
  // A histogram of the current family (type "histogram"): cumulative
  // buckets with their `le` bound, then _sum and _count.
  void histogram(Labels labels, const ArrivalHistogram& h) {
    const std::string family(name_);
    std::uint64_t cumulative = 0;
    std::array<char, 32> le{};
    for (std::size_t i = 0; i < h.buckets.size(); ++i) {
      cumulative += h.buckets[i];
      if (i < kArrivalBounds.size()) {
        std::snprintf(le.data(), le.size(), "%g", kArrivalBounds[i]);
      } else {
        std::snprintf(le.data(), le.size(), "+Inf");
      }
      labelled(family + "_bucket", labels, {"le", le.data()}, static_cast<double>(cumulative));
    }
    labelled(family + "_sum", labels, {}, h.sum_s);
    labelled(family + "_count", labels, {}, static_cast<double>(cumulative));
    name_ = family;
  }
  // One sample of the current family; labels as name/value pairs.
  void sample(Labels labels, double value) {
    out_ += name_;
    if (labels.size() != 0) {
      out_ += '{';
      bool first = true;
      for (const auto& [k, v] : labels) {
        if (!first) out_ += ',';
        first = false;
        out_ += k;
        out_ += '=';
        label_value(out_, v);
      }
      out_ += '}';
    }
    out_ += ' ';
    number(out_, value);
    out_ += '\n';
  }
  std::string take() { return std::move(out_); }

 private:
  // A sample named `name`, with `labels` and one more label when `extra` has a name.
  void labelled(const std::string& name, Labels labels, std::pair<std::string_view, std::string_view> extra,
                double value) {
    name_ = name;
    if (extra.first.empty()) {
      sample(labels, value);
      return;
    }
    sample(labels, value);
    // Insert the extra label before the closing brace of what sample() wrote.
    const std::size_t close = out_.rfind('}');
    std::string add = std::string(labels.size() != 0 ? "," : "") + std::string(extra.first) + "=";
    label_value(add, extra.second);
    if (labels.size() != 0 && close != std::string::npos) {
      out_.insert(close, add);
    } else {
      const std::size_t space = out_.rfind(' ');
      out_.insert(space, "{" + add + "}");
    }
  }

 private:
  std::string out_;
  std::string name_;
};

// The outputs' own figures (ABI 3 stats), one family per figure name: a name
// two plugins both report (e.g. two Modbus instances) is one family with an
// `output` label each, as the format wants.
void output_families(Writer& w, const std::vector<pipeline::OutputStats>& outputs) {
  w.family("cobridge_output_up", "gauge", "1 while the output plugin instance runs.");
  for (const auto& o : outputs) w.sample({{"output", o.instance}, {"type", o.type}}, o.running ? 1 : 0);
  std::map<std::string, std::vector<std::pair<const pipeline::OutputStats*, const pipeline::OutputFigure*>>> by_name;
  for (const auto& o : outputs)
    for (const auto& f : o.figures) by_name[f.name].emplace_back(&o, &f);
  for (const auto& [name, samples] : by_name) {
    const pipeline::OutputFigure& first = *samples.front().second;
    const std::string metric = "cobridge_output_" + name + (first.counter ? "_total" : "");
    w.family(metric, first.counter ? "counter" : "gauge", first.help.empty() ? "An output's own figure." : first.help);
    for (const auto& [o, f] : samples)
      w.sample({{"output", o->instance}, {"type", o->type}}, static_cast<double>(f->value));
  }
}

std::string node_label(const DeviceStatus& d) { return d.node_id == 0 ? std::string() : std::to_string(d.node_id); }

void gateway_families(Writer& w, const control::StatusReport& report) {
  w.family("cobridge_info", "gauge", "The gateway's identity (value 1).");
  w.sample({{"gateway", report.gateway_id}, {"version", report.version}}, 1);
  w.family("cobridge_ready", "gauge", "1 once every known device was configured or timed out (sd_notify READY=1).");
  w.sample({}, report.ready ? 1 : 0);
  w.family("cobridge_start_time_seconds", "gauge", "When the daemon started, seconds since the Unix epoch.");
  w.sample({}, std::chrono::duration<double>(report.started.time_since_epoch()).count());
}

// The CAN controller's fault confinement state (1 for the present one),
// its error counters and restarts, from the bus's error frames.
void controller_families(Writer& w, const control::StatusReport& report) {
  using can::ControllerState;
  w.family("cobridge_bus_controller_state", "gauge",
           "1 for the CAN controller's present state (unknown: no error frame or netlink state yet; error-active, "
           "error-warning, error-passive, bus-off).");
  for (const auto& b : report.buses) {
    for (const ControllerState s : {ControllerState::unknown, ControllerState::error_active,
                                    ControllerState::error_warning, ControllerState::error_passive,
                                    ControllerState::bus_off})
      w.sample({{"bus", b.name}, {"state", can::to_string(s)}}, b.controller.state == s ? 1 : 0);
  }
  w.family("cobridge_bus_controller_errors", "gauge",
           "The controller's transmit / receive error counter as netlink or its last error frame reported it.");
  for (const auto& b : report.buses) {
    if (!b.controller.counters_known) continue;
    w.sample({{"bus", b.name}, {"direction", "tx"}}, b.controller.tx_errors);
    w.sample({{"bus", b.name}, {"direction", "rx"}}, b.controller.rx_errors);
  }
  w.family("cobridge_bus_controller_restarts_total", "counter", "Controller restarts after bus-off.");
  for (const auto& b : report.buses) w.sample({{"bus", b.name}}, static_cast<double>(b.controller.restarts));
}

// Per bus: the interface, the two sockets' counters (docs/architecture.md)
// and what the hot path counted instead of publishing.
void bus_families(Writer& w, const control::StatusReport& report) {
  auto per_bus = [&](std::string_view name, std::string_view type, std::string_view help,
                     const std::function<double(const BusStatus&)>& get) {
    w.family(name, type, help);
    for (const auto& b : report.buses) w.sample({{"bus", b.name}}, get(b));
  };
  w.family("cobridge_bus_open", "gauge", "1 while the bus's CAN interface is open.");
  for (const auto& b : report.buses) w.sample({{"bus", b.name}, {"interface", b.interface}}, b.open ? 1 : 0);
  w.family("cobridge_bus_master", "gauge",
           "[redundancy]: 1 while this gateway is the bus's master, 0 otherwise (standby, electing); "
           "absent without [redundancy].");
  for (const auto& b : report.buses) {
    if (!b.role.empty()) w.sample({{"bus", b.name}, {"role", b.role}}, b.role == "master" ? 1 : 0);
  }
  w.family("cobridge_bus_peer_node", "gauge",
           "[redundancy]: node-ID of the other gateway heard on the bus, 0 = none yet; absent without [redundancy].");
  for (const auto& b : report.buses) {
    if (!b.role.empty()) w.sample({{"bus", b.name}}, b.peer_node);
  }
  per_bus("cobridge_bus_bitrate", "gauge", "The bus's configured bit rate, bit/s.",
          [](const BusStatus& b) { return static_cast<double>(b.bitrate_kbit) * 1000.0; });
  // Each bus has two sockets (docs/architecture.md): the hot path's and the control plane's.
  auto per_socket = [&](std::string_view name, std::string_view help, std::uint64_t BusStatus::*hot,
                        std::uint64_t BusStatus::*control) {
    w.family(name, "counter", help);
    for (const auto& b : report.buses) {
      w.sample({{"bus", b.name}, {"socket", "hot_path"}}, static_cast<double>(b.*hot));
      w.sample({{"bus", b.name}, {"socket", "control"}}, static_cast<double>(b.*control));
    }
  };
  per_socket("cobridge_frames_received_total",
             "CAN frames received, per socket: the hot path's (PDO, EMCY, heartbeat) and the control plane's.",
             &BusStatus::hot_rx_frames, &BusStatus::rx_frames);
  per_bus("cobridge_frames_sent_total", "counter", "CAN frames the kernel accepted from the control plane.",
          [](const BusStatus& b) { return static_cast<double>(b.tx_frames); });
  per_socket("cobridge_kernel_drops_total",
             "Frames the kernel dropped at a socket's receive queue (SO_RXQ_OVFL), per socket.",
             &BusStatus::hot_kernel_drops, &BusStatus::rx_overflow_drops);
  per_bus("cobridge_ring_drops_total", "counter", "Samples lost because the bus's ring to the dispatcher was full.",
          [](const BusStatus& b) { return static_cast<double>(b.ring_drops); });
  per_bus("cobridge_status_event_drops_total", "counter",
          "Status events (online, stale, command outcomes) lost because the bus's control ring was full.",
          [](const BusStatus& b) { return static_cast<double>(b.status_drops); });
  per_bus("cobridge_unknown_node_frames_total", "counter",
          "Frames of nodes no device index belongs to: counted, not published.",
          [](const BusStatus& b) { return static_cast<double>(b.unknown_node_frames); });
  per_bus("cobridge_bad_length_frames_total", "counter",
          "PDO, EMCY or heartbeat frames of the wrong length: not published.",
          [](const BusStatus& b) { return static_cast<double>(b.bad_length_frames); });
  per_bus("cobridge_tx_dropped_total", "counter",
          "Frames the control plane could not send (the kernel's queue stayed full, ENOBUFS).",
          [](const BusStatus& b) { return static_cast<double>(b.tx_dropped); });
  per_bus("cobridge_error_frames_total", "counter", "CAN error frames received (bus-off, passive, warnings).",
          [](const BusStatus& b) { return static_cast<double>(b.error_frames); });
  per_bus("cobridge_bus_reopens_total", "counter", "Times the interface was reopened after it went down.",
          [](const BusStatus& b) { return static_cast<double>(b.reopens); });
  controller_families(w, report);
}

// Per device: how regularly its heartbeats and TPDOs arrive (a device
// drifting towards its heartbeat consumer time shows before it is lost).
void arrival_families(Writer& w, const control::StatusReport& report) {
  w.family("cobridge_heartbeat_interval_seconds", "histogram",
           "Time between two heartbeats of the device, as the outputs received them.");
  for (const auto& b : report.buses) {
    for (const auto& d : b.devices) {
      if (d.values.heartbeat_intervals.count() != 0)
        w.histogram({{"bus", b.name}, {"node", node_label(d)}, {"name", d.name}}, d.values.heartbeat_intervals);
    }
  }
  w.family("cobridge_tpdo_interval_seconds", "histogram", "Time between two TPDOs of the device.");
  for (const auto& b : report.buses) {
    for (const auto& d : b.devices) {
      if (d.values.tpdo_intervals.count() != 0)
        w.histogram({{"bus", b.name}, {"node", node_label(d)}, {"name", d.name}}, d.values.tpdo_intervals);
    }
  }
}

using DeviceValue = std::function<bool(const DeviceStatus&, double&)>;

// One family with a sample per device for which `get` gives a value.
void device_family(Writer& w, const control::StatusReport& report, std::string_view name, std::string_view type,
                   std::string_view help, const DeviceValue& get) {
  w.family(name, type, help);
  for (const auto& b : report.buses) {
    for (const auto& d : b.devices) {
      double v = 0;
      if (get(d, v)) w.sample({{"bus", b.name}, {"node", node_label(d)}, {"name", d.name}}, v);
    }
  }
}

// Per device: the last values and their ages.
void value_families(Writer& w, const control::StatusReport& report) {
  auto per_device = [&](std::string_view name, std::string_view type, std::string_view help, const DeviceValue& get) {
    device_family(w, report, name, type, help, get);
  };
  per_device("cobridge_heartbeat_age_seconds", "gauge", "Time since the device's last heartbeat.",
             [](const DeviceStatus& d, double& v) {
               v = d.values.heartbeat_age_s;
               return v >= 0;
             });
  per_device("cobridge_value_age_seconds", "gauge", "Time since the device's last position or speed was received.",
             [](const DeviceStatus& d, double& v) {
               v = d.values.age_s;
               return d.values.present;
             });
  per_device("cobridge_value_stale", "gauge", "1 while the outputs mark the device's values stale.",
             [](const DeviceStatus& d, double& v) {
               v = d.values.stale ? 1 : 0;
               return d.values.present;
             });
  w.family("cobridge_position", "gauge", "The device's last position in engineering units (label unit).");
  for (const auto& b : report.buses) {
    for (const auto& d : b.devices) {
      if (d.values.present && d.values.has_position)
        w.sample({{"bus", b.name}, {"node", node_label(d)}, {"name", d.name}, {"unit", d.values.unit}},
                 d.values.position_eng);
    }
  }
  per_device("cobridge_speed", "gauge", "The device's last speed, device units (object 0x6030).",
             [](const DeviceStatus& d, double& v) {
               v = d.values.speed;
               return d.values.present && d.values.has_speed;
             });
}

// Per device: liveness, state, counters, then the last values.
void device_families(Writer& w, const control::StatusReport& report) {
  auto per_device = [&](std::string_view name, std::string_view type, std::string_view help, const DeviceValue& get) {
    device_family(w, report, name, type, help, get);
  };
  per_device("cobridge_device_up", "gauge", "1 while the device's heartbeat (or guarding) is heard.",
             [](const DeviceStatus& d, double& v) { v = d.online ? 1 : 0; return true; });
  w.family("cobridge_device_state", "gauge", "The device's state in the gateway (1 for the current state).");
  for (const auto& b : report.buses) {
    for (const auto& d : b.devices) {
      const std::string node = node_label(d);
      for (const DeviceState s : kStates)
        w.sample({{"bus", b.name}, {"node", node}, {"name", d.name}, {"state", bus::to_string(s)}},
                 d.state == s ? 1 : 0);
    }
  }
  per_device("cobridge_device_config_differs", "gauge", "1 while a client left a configured object at another value.",
             [](const DeviceStatus& d, double& v) { v = d.drift.empty() ? 0 : 1; return true; });
  per_device("cobridge_device_config_contested", "gauge",
             "1 while a configured object is contested: written back 3 times within 10 minutes and changed again; "
             "not written until acknowledged.",
             [](const DeviceStatus& d, double& v) { v = contested_count(d) > 0 ? 1 : 0; return true; });
  per_device("cobridge_device_boot_ups_total", "counter", "Boot-up messages seen from the device.",
             [](const DeviceStatus& d, double& v) { v = d.boot_ups; return true; });
  per_device("cobridge_device_configurations_total", "counter", "Configuration plans run on the device (with writes).",
             [](const DeviceStatus& d, double& v) { v = d.configurations; return true; });
  per_device("cobridge_device_emcy_total", "counter", "Emergency messages received from the device.",
             [](const DeviceStatus& d, double& v) { v = d.emcy_count; return true; });
  value_families(w, report);
  arrival_families(w, report);
}

}  // namespace

std::string render_metrics(const control::StatusReport& report) {
  Writer w;
  gateway_families(w, report);
  bus_families(w, report);
  device_families(w, report);
  output_families(w, report.outputs);
  return w.take();
}

}  // namespace cobridge::web
