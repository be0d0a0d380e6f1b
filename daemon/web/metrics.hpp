// Metrics: the status report in the Prometheus text exposition format
// (version 0.0.4), for /metrics. Names follow Prometheus conventions
// (cobridge_ prefix, _total for counters, _seconds for times); labels are
// bus, interface, node, name. Every place a frame or sample can be lost has
// a counter (docs/web.md lists them).
// Thread: any; a pure function of the report.
#pragma once

#include "control/status_report.hpp"

#include <string>

namespace cobridge::web {

[[nodiscard]] std::string render_metrics(const control::StatusReport& report);

}  // namespace cobridge::web
