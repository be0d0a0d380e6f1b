// A status report of `buses` x `devices` operational devices with values,
// EMCYs and awkward names, for the web tests.
#pragma once

#include "control/status_report.hpp"

#include <chrono>
#include <string>

namespace cobridge::web::test {

// Users for the authentication tests: crypt(3) hashes made with
// `openssl passwd -6 -salt aliceSalt 's3cret'` and `... -salt bobSalt 'hunter:2'`.
inline constexpr const char* kAliceHash =
    "$6$aliceSalt$GWaoQP4ejM4uMr3JQOephVSTIhnZxBBq.ICGLg73B16sy1dAN1jClN0Q8yfRP84CyNQha.vBsBvupt/hP4OTC/";
inline constexpr const char* kBobHash =
    "$6$bobSalt$vcMPHIEgVxXbrTFn0iYwC4ucNZXRWDHHonu8HLqTYkUiQ8dLrf5DkUTJLNRXwiQ2HgbgACEFqQyE0hIJB6eCT.";

inline control::StatusReport sample_report(int buses, int devices) {
  using namespace std::chrono_literals;
  control::StatusReport r;
  r.gateway_id = "gw-1";
  r.version = "0.1.0";
  r.pid = 42;
  r.ready = true;
  r.started = bus::WallTime(1700000000s);
  r.config_file = "/etc/cobridge/cobridge.toml";
  for (int b = 0; b < buses; ++b) {
    bus::BusStatus bus;
    bus.name = "line" + std::to_string(b + 1);
    bus.controller.counters_known = b == 0;  // the first bus's adapter reports its error counters
    bus.controller.tx_errors = 12;
    bus.controller.state = b == 0 ? can::ControllerState::error_active : can::ControllerState::unknown;
    bus.interface = "can" + std::to_string(b);
    bus.open = true;
    bus.bitrate_kbit = 250;
    bus.rx_frames = 1000;
    bus.hot_rx_frames = 50000;
    bus.ring_drops = 0;
    for (int d = 0; d < devices; ++d) {
      bus::DeviceStatus dev;
      dev.name = "enc-" + std::to_string(b) + "-" + std::to_string(d);
      dev.bus = bus.name;
      dev.node_id = static_cast<std::uint8_t>(d + 1);
      dev.identity = {0x2D4, 0x1234, 1, static_cast<std::uint32_t>(1000 + d)};
      dev.model = "RFC-4800";
      dev.family = "novotechnik-rotary";
      dev.state = d == 1 ? bus::DeviceState::offline : bus::DeviceState::operational;
      dev.nmt = canopen::NmtState::operational;
      dev.online = d != 1;
      dev.emcy_count = 1;
      dev.last_emcy_code = 0x5000;
      dev.last_emcy_text = "hardware fault";
      dev.emcy_history.push_back({0x5000, "hardware fault", bus::WallTime(1700000100s)});
      dev.values.present = true;
      dev.values.has_position = true;
      dev.values.has_speed = true;
      dev.values.position = 1234 + d;
      dev.values.position_eng = 12.5 + d;
      dev.values.unit = "deg";
      dev.values.speed = -3;
      dev.values.age_s = 0.05;
      dev.values.stale = d == 1;
      // Heartbeats every 100 ms and one late at 300 ms; TPDOs every 10 ms.
      dev.values.heartbeat_intervals.buckets[6] = 20;  // <= 0.1 s
      dev.values.heartbeat_intervals.buckets[8] = 1;   // <= 0.5 s
      dev.values.heartbeat_intervals.sum_s = 2.3;
      dev.values.tpdo_intervals.buckets[3] = 200;      // <= 0.01 s
      dev.values.tpdo_intervals.sum_s = 2.0;
      dev.values.heartbeat_age_s = 0.1;
      bus.devices.push_back(dev);
    }
    r.buses.push_back(bus);
  }
  // Two outputs of one type reporting the same figures, one stopped output.
  for (const char* instance : {"modbus", "modbus_scada2"}) {
    pipeline::OutputStats o{instance, "modbus", true, {}};
    o.figures.push_back({"modbus_clients_connected", "Modbus TCP connections open now.", false, 3});
    o.figures.push_back({"modbus_requests", "Modbus requests answered.", true, 1200});
    r.outputs.push_back(o);
  }
  r.outputs.push_back({"dds", "dds", false, {}});
  // A name that needs escaping in labels and JSON.
  if (!r.buses.empty() && !r.buses[0].devices.empty()) r.buses[0].devices[0].name = "odd \"name\\";
  return r;
}

}  // namespace cobridge::web::test
