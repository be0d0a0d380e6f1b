// The [logging] settings applied to the process's loggers (at start and on
// every accepted reload).
//
// Thread: the main thread, while no other thread logs through a logger being
// replaced (start-up), or between log lines (spdlog's levels are atomic).
#pragma once

#include "config/config.hpp"

namespace cobridge::app {

// `foreground` (cobridged -f) sends the log to the console whatever the
// configuration says.
void apply_logging(const config::LoggingSettings& logging, bool foreground);

}  // namespace cobridge::app
