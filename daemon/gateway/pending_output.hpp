// send_pending: writes what a non-blocking socket takes of an answer queued
// for one client; shared by the control socket and the CiA 309-3 gateway,
// which serve their clients the same way.
//
// Threads: the thread that owns the client (each server's own).
#pragma once

#include <cstddef>
#include <string>

namespace cobridge::gateway {

// Sends out[done..] without blocking and advances `done`. When all of it is
// out, clears `out` and resets `done`. Returns false when the client is gone
// (an error other than EAGAIN / EINTR), true otherwise.
[[nodiscard]] bool send_pending(int fd, std::string& out, std::size_t& done);

}  // namespace cobridge::gateway
