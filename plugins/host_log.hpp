// Reporting to the daemon from a plugin: log lines through the host API's
// log callback, the error text create() hands back in the caller's buffer
// (cobridge/plugin.h), the figures of the stats operation, and the frame of
// create() itself. Shared by the output
// plugins so that each reports the same way.
//
// Thread: the control thread (create/start/stop/destroy), the control plane
// (copy_stats, from the stats operation) and the plugin's own
// threads; the host's log callback is thread-safe. Not for the hot path: the
// message is a std::string.
#pragma once

#include <cobridge/plugin.h>
#include <cobridge/plugin_error.hpp>

#include <cstddef>
#include <cstring>
#include <exception>
#include <string>
#include <string_view>

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

// An ABI 3 stats operation's answer: copies the plugin's figures into the
// host's array, at most `max`; returns how many. Allocation-free.
template <std::size_t N>
inline std::size_t copy_stats(const cobridge_stat (&figures)[N], cobridge_stat* out, std::size_t max) noexcept {
  std::size_t n = 0;
  for (const auto& f : figures) {
    if (n == max) break;
    out[n++] = f;
  }
  return n;
}

// The frame of a plugin's cobridge_plugin_create: checks the arguments,
// hands `make(config, error)` the configuration text and keeps exceptions
// from unwinding into the host. `make` returns the new instance, or nullptr
// with `error` (a plugin::Error) set. Returns 0 with *ops_out and *self_out
// set, else -1 with the error's message in `err`.
template <typename Make>
int create_plugin(const char* name, const cobridge_plugin_ops* ops, const cobridge_host_api* host,
                  const char* config_toml, std::size_t config_len, const cobridge_plugin_ops** ops_out,
                  void** self_out, char* err, std::size_t err_len, Make&& make) noexcept {
  if (host == nullptr || ops_out == nullptr || self_out == nullptr) {
    copy_error(err, err_len, std::string(name) + ": null argument");
    return -1;
  }
  try {
    const std::string_view config(config_toml != nullptr ? config_toml : "", config_toml != nullptr ? config_len : 0);
    Error error;
    void* self = make(config, error);
    if (self == nullptr) {
      copy_error(err, err_len, error ? error.message : std::string(name) + ": create failed");
      return -1;
    }
    *ops_out = ops;
    *self_out = self;
    return 0;
  } catch (const std::exception& e) {
    copy_error(err, err_len, std::string(name) + ": " + e.what());
  } catch (...) {
    copy_error(err, err_len, std::string(name) + ": unknown exception");
  }
  return -1;
}

}  // namespace cobridge::plugin
