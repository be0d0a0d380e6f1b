// What a SIGHUP reload may change while the daemon runs. The buses stay open,
// the plugins and the web service run with the settings they were started
// with, and the state file and control socket stay where they are: a new
// configuration that changes any of these is refused (it needs a restart)
// rather than half applied.
//
// Thread: the main thread (reload); pure functions.
#pragma once

#include "config/config.hpp"

#include <string>

namespace cobridge::app {

// Why `next` cannot replace `running` without a restart, or "" when it can
// (as far as the daemon's own parts go; the outputs are asked separately).
[[nodiscard]] std::string reload_refusal(const config::Config& running, const config::Config& next);

}  // namespace cobridge::app
