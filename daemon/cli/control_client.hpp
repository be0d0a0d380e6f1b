// ControlClient: one request line to cobridged's control socket
// (control/control_server.hpp), one JSON answer line back.
// Thread: the CLI's main thread; blocking I/O with a timeout.
#pragma once

#include "base/result.hpp"

#include <optional>
#include <string>

namespace cobridge::cli {

// The daemon's control socket unless --control names another.
inline constexpr const char* kDefaultControlSocket = "/run/cobridge/control.sock";

// Sends `line`, returns the answer line (without newline), or the failure:
// kPermissionDenied when the socket may not be opened (EACCES, EPERM: the
// caller is not the service's user or in its group; no retry helps),
// kTimeout when no answer came in time, else kUnavailable.
// `no_daemon` (optional) is set when nothing listens on `path` (no socket
// file, or connection refused): the caller may then work on the bus itself.
[[nodiscard]] Result<std::string> request(const std::string& path, const std::string& line, int timeout_ms,
                                          bool* no_daemon = nullptr);

}  // namespace cobridge::cli
