// stop_signal_fd: SIGTERM and SIGINT blocked and read from a signalfd, so a
// tool's poll loop ends cleanly when a test stops it.
//
// Thread: call once from main() before any thread starts.
#pragma once

namespace cobridge::sim::tools {

// The signalfd (close-on-exec), or -1 with errno set.
int stop_signal_fd() noexcept;

}  // namespace cobridge::sim::tools
