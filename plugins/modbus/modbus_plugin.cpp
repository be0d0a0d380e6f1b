// The Modbus TCP output plugin (libcobridge_modbus.so): entry point and ops
// table. It owns the RegisterImage (written by on_samples / on_device on the
// dispatcher thread) and the TcpServer (its own thread, reading the image).
// The hot path is one seqlock publish per sample: no allocation, no lock, no
// log.
//
// Writes (writes_enabled = true): the command registers of each device slot
// (CommandRegisters) hand preset / NMT reset / store to the daemon through
// host->submit_command (ABI 2); the outcome comes back as a COMMAND sample.
// A daemon without submit_command (ABI 1) refuses every command (0x04).
// See docs/modbus.md.
//
// Threads: create/start/stop/destroy on the daemon's control thread;
// on_samples/on_device on the dispatcher thread; the server thread inside
// TcpServer.
#include "command_registers.hpp"
#include "register_image.hpp"
#include "server_config.hpp"
#include "tcp_server.hpp"

#include <cobridge/plugin.h>

#include "host_log.hpp"

#include <cstddef>
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
  std::unique_ptr<CommandRegisters> commands;  // writes_enabled only
  std::unique_ptr<TcpServer> server;

  // host->submit_command exists from ABI 2 on.
  [[nodiscard]] bool host_takes_commands() const noexcept {
    return host->struct_size >= offsetof(cobridge_host_api, submit_command) + sizeof(host->submit_command) &&
           host->submit_command != nullptr;
  }

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
    p->server = std::make_unique<TcpServer>(
        p->config, *p->image, [p](int level, const std::string& m) { p->log(level, m); }, p->commands.get());
    if (const plugin::Error e = p->server->start()) {
      p->log(COBRIDGE_LOG_ERROR, "cannot start the Modbus server: " + e.to_string());
      p->server.reset();
      return -1;
    }
    if (p->config.writes_enabled && !p->host_takes_commands()) {
      p->log(COBRIDGE_LOG_WARN,
             "writes_enabled = true, but this daemon (plugin ABI " + std::to_string(p->host->abi_version) +
                 ") takes no commands from plugins: commands are refused with exception 0x04");
    } else if (p->config.writes_enabled) {
      p->log(COBRIDGE_LOG_INFO, "writes enabled: preset, NMT reset and store through the command registers");
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
                                  std::to_string(s.refused_allow + s.refused_full) + " refused, " +
                                  std::to_string(s.closed_silent) + " closed without a first request, " +
                                  std::to_string(s.evicted) + " evicted when full, " +
                                  std::to_string(s.accept_pauses) + " accept pauses (out of descriptors)");
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
  for (std::size_t i = 0; i < count; ++i) {
    p->image->apply(samples[i]);
    if (p->commands) p->commands->on_sample(samples[i]);
  }
}

void modbus_on_device(void* self, const cobridge_device_info* info) {
  auto* p = static_cast<Plugin*>(self);
  if (info == nullptr || info->struct_size < offsetof(cobridge_device_info, serial) + sizeof(info->serial)) return;
  p->image->apply(*info);
}

// ABI 5: a bus's health (CAN controller state, error counters, restarts).
void modbus_on_bus(void* self, const cobridge_bus_info* info) {
  auto* p = static_cast<Plugin*>(self);
  if (info == nullptr || info->struct_size < offsetof(cobridge_bus_info, restarts) + sizeof(info->restarts)) return;
  p->image->apply(*info);
}

// ABI 3: what the status page and /metrics show of this output. Control-plane
// thread; the server's counters are atomics, so this only loads them.
std::size_t modbus_stats(void* self, cobridge_stat* out, std::size_t max) {
  const auto* p = static_cast<const Plugin*>(self);
  if (!p->server) return 0;
  const ServerStats s = p->server->stats();
  const cobridge_stat figures[] = {
      {"modbus_clients_connected", "Modbus TCP connections open now.", COBRIDGE_STAT_GAUGE, 0, s.connected},
      {"modbus_connections", "Modbus TCP connections accepted.", COBRIDGE_STAT_COUNTER, 0, s.accepted},
      {"modbus_refused", "Modbus TCP connections refused (allow list, max_clients).", COBRIDGE_STAT_COUNTER, 0,
       s.refused_allow + s.refused_full},
      {"modbus_requests", "Modbus requests answered.", COBRIDGE_STAT_COUNTER, 0, s.requests},
      {"modbus_exceptions", "Modbus exception responses sent.", COBRIDGE_STAT_COUNTER, 0, s.exceptions},
  };
  return plugin::copy_stats(figures, out, max);
}

constexpr cobridge_plugin_ops kOps = {
    COBRIDGE_PLUGIN_ABI_VERSION, sizeof(cobridge_plugin_ops), "modbus", &modbus_start, &modbus_stop,
    &modbus_destroy,             &modbus_on_samples,          &modbus_on_device, &modbus_stats,
    nullptr,  // on_role: both gateways of a pair serve live registers; SCADA may poll either
    &modbus_on_bus,
};

}  // namespace
}  // namespace cobridge::modbus

extern "C" COBRIDGE_PLUGIN_EXPORT int cobridge_plugin_create(const cobridge_host_api* host, const char* config_toml,
                                                             size_t config_len, const cobridge_plugin_ops** ops_out,
                                                             void** self_out, char* err, size_t err_len) {
  using namespace cobridge::modbus;
  return cobridge::plugin::create_plugin(
      "modbus", &kOps, host, config_toml, config_len, ops_out, self_out, err, err_len,
      [host](std::string_view config, cobridge::plugin::Error& error) -> void* {
        auto p = std::make_unique<Plugin>();
        p->host = host;
        error = parse_config(config, p->config);
        if (error) return nullptr;
        ImageOptions io;
        io.device_slots = p->config.max_devices;
        io.word_order = p->config.word_order;
        io.writes_enabled = p->config.writes_enabled;
        io.offline_exception = p->config.offline_exception;
        io.version_major = COBRIDGE_VERSION_MAJOR;
        io.version_minor = COBRIDGE_VERSION_MINOR;
        io.version_patch = COBRIDGE_VERSION_PATCH;
        p->image = std::make_unique<RegisterImage>(io);
        if (p->config.writes_enabled) {
          Plugin* raw = p.get();
          p->commands = std::make_unique<CommandRegisters>(*p->image, [raw](const cobridge_command& c) {
            return raw->host_takes_commands() ? raw->host->submit_command(raw->host->host, &c)
                                              : static_cast<int>(COBRIDGE_COMMAND_UNSUPPORTED);
          });
          p->image->attach(p->commands.get());
        }
        return p.release();
      });
}
