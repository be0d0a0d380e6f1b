// Reporting to the daemon from a plugin: log lines through the host API's
// log callback, and the error text create() hands back in the caller's
// buffer (cobridge/plugin.h). Shared by the output plugins so that each
// reports the same way.
//
// Thread: the control thread (create/start/stop/destroy) and the plugin's own
// threads; the host's log callback is thread-safe. Not for the hot path: the
// message is a std::string.
#pragma once

#include <cobridge/plugin.h>

#include <cstddef>
#include <cstring>
#include <string>

namespace cobridge::plugin {

// Logs `msg` through the host; silent when the host gave no log callback.
inline void host_log(const cobridge_host_api* host, int level, const std::string& msg) noexcept {
  if (host != nullptr && host->log != nullptr) host->log(host->host, level, msg.c_str());
}

// Copies `msg` into the caller's buffer, truncated to fit and always
// NUL-terminated; nothing when there is no buffer.
inline void copy_error(char* err, std::size_t err_len, const std::string& msg) noexcept {
  if (err == nullptr || err_len == 0) return;
  const std::size_t n = msg.size() < err_len - 1 ? msg.size() : err_len - 1;
  std::memcpy(err, msg.data(), n);
  err[n] = '\0';
}

}  // namespace cobridge::plugin
