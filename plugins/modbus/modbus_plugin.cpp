// The Modbus TCP output plugin (libcobridge_modbus.so): entry point and ops
// table. It owns the RegisterImage (written by on_samples / on_device on the
// dispatcher thread) and the TcpServer (its own thread, reading the image).
// The hot path is one seqlock publish per sample: no allocation, no lock, no
// log.
//
// Writes: plugin ABI 1 has no operation through which a plugin can hand a
// command (preset, NMT reset, store) to the daemon, so this version answers
// every write request with an exception (0x01 while writes_enabled = false,
// 0x02 when true: no register is writable). See docs/modbus.md.
//
// Threads: create/start/stop/destroy on the daemon's control thread;
// on_samples/on_device on the dispatcher thread; the server thread inside
// TcpServer.
#include "register_image.hpp"
#include "server_config.hpp"
#include "tcp_server.hpp"

#include <cobridge/plugin.h>

#include "host_log.hpp"

#include <cstring>
#include <ctime>
#include <memory>
#include <string>

#ifndef COBRIDGE_VERSION_MAJOR
#define COBRIDGE_VERSION_MAJOR 0
#define COBRIDGE_VERSION_MINOR 0
#define COBRIDGE_VERSION_PATCH 0
#endif

namespace cobridge::modbus {
namespace {

struct Plugin {
  const cobridge_host_api* host = nullptr;
  ServerConfig config;
  std::unique_ptr<RegisterImage> image;
  std::unique_ptr<TcpServer> server;

  void log(int level, const std::string& msg) const noexcept {
    plugin::host_log(host, level, msg);
  }
};

using plugin::copy_error;

std::uint64_t monotonic_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000u + static_cast<std::uint64_t>(ts.tv_nsec);
}

int modbus_start(void* self) {
  auto* p = static_cast<Plugin*>(self);
  try {
    p->image->set_start(monotonic_ns());
    p->server = std::make_unique<TcpServer>(p->config, *p->image, [p](int level, const std::string& m) { p->log(level, m); });
    std::string message;
    if (const std::error_code ec = p->server->start(message)) {
      p->log(COBRIDGE_LOG_ERROR, "cannot start the Modbus server: " + message);
      p->server.reset();
      return -1;
    }
    if (p->config.writes_enabled) {
      p->log(COBRIDGE_LOG_WARN,
             "writes_enabled = true, but plugin ABI 1 has no way to pass writes to the daemon: write requests "
             "are refused with exception 0x02");
    }
    p->log(COBRIDGE_LOG_INFO, "Modbus TCP listening on " + p->server->endpoint() + " (" +
                                  std::to_string(p->config.max_devices) + " device slots, max " +
                                  std::to_string(p->config.max_clients) + " clients)");
    return 0;
  } catch (const std::exception& e) {
    p->log(COBRIDGE_LOG_ERROR, std::string("cannot start: ") + e.what());
  } catch (...) {
    p->log(COBRIDGE_LOG_ERROR, "cannot start: unknown exception");
  }
  p->server.reset();
  return -1;
}

void modbus_stop(void* self) {
  auto* p = static_cast<Plugin*>(self);
  if (!p->server) return;
  p->server->stop();
  const ServerStats s = p->server->stats();
  try {
    p->log(COBRIDGE_LOG_INFO, "Modbus TCP stopped: " + std::to_string(s.accepted) + " connections, " +
                                  std::to_string(s.requests) + " requests (" + std::to_string(s.exceptions) +
                                  " exceptions), " + std::to_string(s.closed_protocol) + " closed for framing errors, " +
                                  std::to_string(s.refused_allow + s.refused_full) + " refused");
  } catch (...) {
  }
  p->server.reset();
}

void modbus_destroy(void* self) {
  auto* p = static_cast<Plugin*>(self);
  modbus_stop(p);
  delete p;
}

void modbus_on_samples(void* self, const cobridge_sample* samples, std::size_t count) {
  auto* p = static_cast<Plugin*>(self);
  for (std::size_t i = 0; i < count; ++i) p->image->apply(samples[i]);
}

void modbus_on_device(void* self, const cobridge_device_info* info) {
  auto* p = static_cast<Plugin*>(self);
  if (info == nullptr || info->struct_size < offsetof(cobridge_device_info, serial) + sizeof(info->serial)) return;
  p->image->apply(*info);
}

constexpr cobridge_plugin_ops kOps = {
    COBRIDGE_PLUGIN_ABI_VERSION, sizeof(cobridge_plugin_ops), "modbus", &modbus_start, &modbus_stop,
    &modbus_destroy,             &modbus_on_samples,          &modbus_on_device,
};

}  // namespace
}  // namespace cobridge::modbus

extern "C" COBRIDGE_PLUGIN_EXPORT int cobridge_plugin_create(const cobridge_host_api* host, const char* config_toml,
                                                             size_t config_len, const cobridge_plugin_ops** ops_out,
                                                             void** self_out, char* err, size_t err_len) {
  using namespace cobridge::modbus;
  if (host == nullptr || ops_out == nullptr || self_out == nullptr) {
    copy_error(err, err_len, "modbus: null argument");
    return -1;
  }
  try {
    auto p = std::make_unique<Plugin>();
    p->host = host;
    const ConfigResult r = parse_config(
        std::string_view(config_toml != nullptr ? config_toml : "", config_toml != nullptr ? config_len : 0), p->config);
    if (!r) {
      copy_error(err, err_len, r.message);
      return -1;
    }
    ImageOptions io;
    io.device_slots = p->config.max_devices;
    io.word_order = p->config.word_order;
    io.writes_enabled = p->config.writes_enabled;
    io.offline_exception = p->config.offline_exception;
    io.version_major = COBRIDGE_VERSION_MAJOR;
    io.version_minor = COBRIDGE_VERSION_MINOR;
    io.version_patch = COBRIDGE_VERSION_PATCH;
    p->image = std::make_unique<RegisterImage>(io);
    *ops_out = &kOps;
    *self_out = p.release();
    return 0;
  } catch (const std::exception& e) {
    copy_error(err, err_len, std::string("modbus: ") + e.what());
  } catch (...) {
    copy_error(err, err_len, "modbus: unknown exception");
  }
  return -1;
}
