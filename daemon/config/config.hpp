// Config: the daemon's configuration as plain values, the result of loading
// the TOML file (see load.hpp and docs/configuration.md). It holds no TOML
// types and no CAN/CANopen types: the gateway turns it into bus managers and
// SDO configuration plans, main.cpp into logging settings and plugins.
//
// A device setting left out of the file is an empty optional and means "do
// not touch the device's value"; bus and gateway settings get their
// documented defaults instead.
//
// Thread contract: built once by load() on the start-up / reload thread, then
// read-only; safe to read from any thread once published.
#pragma once

#include "config/service_access.hpp"

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace cobridge::config {

// Where a value came from, for messages that point back at the file.
struct SourceLocation {
  std::string file;
  std::uint32_t line = 0;    // 1-based; 0 = unknown
  std::uint32_t column = 0;  // 1-based; 0 = unknown

  // "file:line:column" ("file" when the line is unknown): the `where` of an
  // Error about this place (diagnostic.cpp).
  [[nodiscard]] std::string to_string() const;
};

// ---- [gateway] -----------------------------------------------------------

struct GatewaySettings {
  std::string id;  // DDS key of this gateway; default: the host name
  std::filesystem::path state_dir;
  // The installed device directory first, then the configured extras.
  std::vector<std::filesystem::path> device_dirs;
  std::filesystem::path control_socket;
};

// ---- [logging] -----------------------------------------------------------

// Same order and values as spdlog::level::level_enum, so main can cast.
enum class LogLevel : std::uint8_t { trace = 0, debug = 1, info = 2, warn = 3, error = 4, critical = 5, off = 6 };
enum class LogTarget : std::uint8_t { automatic, console, journal };

struct LoggingSettings {
  LogLevel level = LogLevel::info;
  LogTarget target = LogTarget::automatic;
  // module name -> level, in file order; only the modules the file names.
  std::vector<std::pair<std::string, LogLevel>> modules;
};

// ---- [[bus]] -------------------------------------------------------------

enum class Commissioning : std::uint8_t { automatic, manual, off };
enum class SwapPolicy : std::uint8_t { same_model, off };
// What the gateway does when another NMT master (a service tool, a PLC)
// stops a device it started or sends it to pre-operational: start it again
// (configuring it first if needed) and log that it happened, or leave it as
// the other master wants it and show that in the status.
enum class ForeignNmt : std::uint8_t { restart, respect };
// A non-configured device (FFh) the configuration does not name: left at
// FFh and reported, or given the next free node-ID of the bus's node_pool
// (stored in the device) and reported; never configured beyond that.
enum class UnknownDevices : std::uint8_t { ignore, assign };

struct Bus {
  std::string name;
  std::string interface;                // Linux interface name, <= 15 chars
  std::uint16_t bitrate_kbit = 125;     // expected bit rate of the bus
  std::uint32_t sync_period_ms = 0;     // 0 = the gateway produces no SYNC
  std::uint8_t sync_counter = 0;        // CiA 301 0x1019: 0 or 2..240
  bool discovery = true;
  std::uint32_t discovery_period_s = 10;
  std::vector<std::uint8_t> node_pool;  // sorted, unique, each 1..127
  bool node_pool_default = false;       // not written: 1..127 (less [redundancy] node_id)
  Commissioning commissioning = Commissioning::automatic;
  SwapPolicy swap_policy = SwapPolicy::same_model;
  std::uint32_t lss_timeout_ms = 100;     // ceiling of every LSS wait
  std::uint32_t lss_timeout_min_ms = 10;  // floor of the waits learnt from answer times
  std::uint32_t sdo_timeout_ms = 500;
  std::uint8_t sdo_retries = 2;
  ForeignNmt foreign_nmt = ForeignNmt::restart;
  UnknownDevices unknown_devices = UnknownDevices::ignore;
  // Flight recorder: the last recorder_seconds of frames kept in memory (0 =
  // off), written around each fault with capture_after_s after it (0.5..60 s,
  // kept in ms); this bus's capture files take at most capture_cap_mib on
  // disk, and at most capture_budget_per_hour are written in an hour (the
  // flash's wear; the cap bounds the space, not the writes).
  std::uint32_t recorder_seconds = 10;
  std::uint32_t capture_after_ms = 2000;
  std::uint32_t capture_cap_mib = 64;
  std::uint32_t capture_budget_per_hour = 60;
  SourceLocation where;  // the [[bus]] header
};

// ---- [[device]] ----------------------------------------------------------

// A symbolic PDO mapping entry; the gateway resolves it to the object of the
// device's family (e.g. position = 0x6020/1 on the rotary series, 0x6004 on
// the multiturn series and ifm). `raw` uses the CiA 301 mapping-entry layout
// index<<16 | subindex<<8 | bit length.
enum class Signal : std::uint8_t { position, speed, cam, work_area, alarms, warnings, temperature, voltage, raw };

struct MappingEntry {
  Signal signal = Signal::raw;
  std::uint32_t raw = 0;  // only for Signal::raw
  friend bool operator==(const MappingEntry&, const MappingEntry&) = default;
};

struct TpdoSettings {
  std::optional<std::vector<MappingEntry>> mapping;
  std::optional<std::uint8_t> transmission;  // CiA 301 transmission type: 0..240, 254, 255
  std::optional<std::uint16_t> event_timer_ms;
  std::optional<std::uint16_t> inhibit_100us;
};

struct Guarding {
  std::uint16_t guard_time_ms = 0;   // CiA 301 0x100C
  std::uint8_t life_time_factor = 0;  // CiA 301 0x100D
};

// Values of bit 0 of CiA 406 object 0x6000 (code sequence).
enum class Direction : std::uint8_t { cw = 0, ccw = 1 };

struct Scaling {
  std::optional<std::uint32_t> units_per_rev;  // 0x6001
  std::optional<std::uint32_t> total_range;    // 0x6002
};

enum class CamPolarity : std::uint8_t { normal = 0, inverted = 1 };

struct Cam {
  std::uint8_t index = 0;  // 1..8
  std::optional<std::int64_t> low;
  std::optional<std::int64_t> high;
  std::optional<std::uint16_t> hysteresis;
  std::optional<bool> enabled;
  std::optional<CamPolarity> polarity;
};

struct WorkArea {
  std::optional<std::int32_t> low;
  std::optional<std::int32_t> high;
};

// When the gateway writes 'save' to 0x1010 after configuring the device.
enum class StorePolicy : std::uint8_t { on_change, always, never };

// What the gateway does when a client (CLI, CiA 309-3, Modbus command)
// writes an object the configuration sets to another value: write the
// configuration again at once, or leave the operator's value until the
// device's next configuration (reboot, reload, re-plug).
enum class DriftPolicy : std::uint8_t { restore, keep };

struct Device {
  std::string name;
  std::string bus;
  std::size_t bus_index = 0;  // index into Config::buses
  std::uint32_t serial = 0;   // CiA 301 0x1018/4
  std::optional<std::uint32_t> vendor;
  std::optional<std::uint32_t> product;
  std::optional<std::uint8_t> node_id;  // 1..127; empty = assign from the pool
  std::string model;                    // a known model name, or empty
  std::optional<std::uint8_t> channels; // 1 or 2, rotary series only
  std::filesystem::path eds;            // absolute, or empty

  std::optional<TpdoSettings> tpdo1;
  std::optional<TpdoSettings> tpdo2;
  std::optional<std::uint16_t> heartbeat_ms;
  std::optional<Guarding> guarding;
  std::optional<Direction> direction;
  std::optional<Scaling> scaling;
  std::optional<std::int64_t> preset;
  std::vector<Cam> cams;  // sorted by index
  std::optional<WorkArea> work_area;
  std::optional<std::uint8_t> position_filter;
  std::optional<std::uint8_t> speed_filter;
  StorePolicy store = StorePolicy::on_change;
  DriftPolicy on_config_drift = DriftPolicy::restore;
  SourceLocation where;  // the [[device]] header
};

// ---- [web] ---------------------------------------------------------------

// [redundancy]: a hot-standby pair of gateways on the same buses
// (docs/operations.md "Hot standby"); absent = the only master.
struct RedundancySettings {
  std::uint8_t node_id = 0;   // this gateway's node-ID on every bus: heartbeat and claims
  std::uint8_t priority = 0;  // 0 (high) .. 2 (low); equal priorities: the lower node-ID
  std::chrono::milliseconds heartbeat{100};  // the master's (and the standby's) heartbeat
  bool preempt = false;       // take the role back from a gateway of lower rank
  std::chrono::seconds hold{10};  // ... after this long as standby
};

// The read-only HTTP status service (daemon/web/, docs/web.md): not an
// output plugin, a control-plane service of the daemon.
struct WebSettings {
  bool enabled = true;
  std::string bind = "127.0.0.1";  // an IPv4 or IPv6 address literal
  std::uint16_t port = 8080;
  std::filesystem::path tls_cert;   // PEM; both or neither of cert and key
  std::filesystem::path tls_key;
  std::filesystem::path auth_file;  // "user:hash" lines (crypt(3) hashes); empty = no authentication
  std::uint32_t max_clients = 64;   // connections at once; more are refused
  std::uint32_t timeout_s = 10;     // an idle or slow connection is closed after this
  // The names a request's Host may carry besides the address the connection
  // arrived at (and localhost on a loopback connection), canonical
  // (config/host_name.hpp); DNS rebinding defence, docs/web.md. Absent: for
  // a wildcard bind, any Host (with a warning); else just those defaults.
  std::optional<std::vector<std::string>> hosts;
  SourceLocation where;             // the [web] header
  SourceLocation tls_cert_at, tls_key_at, auth_file_at, hosts_at;
};

// ---- [outputs.<name>] ----------------------------------------------------

struct Output {
  std::string name;     // the <name> of [outputs.<name>]
  bool enabled = true;
  std::string plugin;   // plugin file name; empty = derived from `name` by the host
  // The rest of the table, serialized as TOML, for the plugin to parse.
  std::string settings_toml;
  SourceLocation where;  // the [outputs.<name>] header
};

struct Config {
  std::filesystem::path source;  // the file this was loaded from
  GatewaySettings gateway;
  LoggingSettings logging;
  std::vector<Bus> buses;
  std::vector<Device> devices;
  std::vector<Output> outputs;
  std::optional<WebSettings> web;  // absent = no web service
  std::optional<RedundancySettings> redundancy;  // absent = no standby: this gateway is master
  ServiceAccess services;             // [control], [ascii_gateway]

  [[nodiscard]] const Bus* find_bus(std::string_view name) const noexcept {
    for (const auto& b : buses) {
      if (b.name == name) return &b;
    }
    return nullptr;
  }
  [[nodiscard]] const Device* find_device(std::string_view name) const noexcept {
    for (const auto& d : devices) {
      if (d.name == name) return &d;
    }
    return nullptr;
  }
  [[nodiscard]] const Output* find_output(std::string_view name) const noexcept {
    for (const auto& o : outputs) {
      if (o.name == name) return &o;
    }
    return nullptr;
  }
};

}  // namespace cobridge::config
