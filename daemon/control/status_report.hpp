// StatusReport: the status document, the one schema that `cobridge status
// --json`, the control socket's `status`, the web service's /api/v1/status
// and its /metrics are made from, and its one writer (to_json).
//
// Thread: plain values and pure functions; any thread. The daemon's main
// loop fills a report from the bus managers (BusManager::status) and the
// output pipeline.
#pragma once

#include "bus/device_status.hpp"
#include "pipeline/plugin_host.hpp"

#include <string>
#include <vector>

namespace cobridge::control {

// Everything `cobridge status` shows: the daemon, then each bus.
struct StatusReport {
  std::string gateway_id;
  std::string version;
  long pid = 0;
  bool ready = false;  // READY=1 has been told (all known devices configured or timed out)
  bus::WallTime started{};
  std::string config_file;
  std::vector<bus::BusStatus> buses;
  std::vector<pipeline::OutputStats> outputs;  // each output plugin's own figures
};

// The `status` answer: the report as one line of JSON (no newline).
[[nodiscard]] std::string to_json(const StatusReport& report);
// "2 buses, 5/6 devices operational" (sd_notify STATUS=, log lines).
[[nodiscard]] std::string summary(const std::vector<bus::BusStatus>& buses);

}  // namespace cobridge::control
