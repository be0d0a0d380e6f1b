// What the gateway knows about each bus and device, as plain snapshot values.
//
// The bus manager owns the live state on its control thread and hands out
// copies (status()); the control socket (`cobridge status`), sd_notify STATUS
// and the output plugins read those copies. Nothing here is on the hot path.
#pragma once

#include "can/controller_health.hpp"
#include "base/arrival_histogram.hpp"
#include "bus/capture_writer.hpp"
#include "bus/device_timeline.hpp"
#include "canopen/lss.hpp"
#include "canopen/nmt.hpp"

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace cobridge::bus {

// A device's place in the gateway's life cycle.
enum class DeviceState : std::uint8_t {
  expected,       // in the configuration, not seen yet
  identified,     // seen and identified (0x1018), not yet configured
  commissioning,  // being given its node-ID (LSS / SDO) and reset
  configuring,    // SDO configuration plan running
  operational,    // configured, started, heartbeat/guarding fresh
  offline,        // was operational; heartbeat/guarding lost, or silent
  failed,         // configuration or commissioning failed; see last_error
  stopped,        // configured, but NMT-stopped by another master (heartbeat state 0x04)
};
[[nodiscard]] const char* to_string(DeviceState s) noexcept;

using WallTime = std::chrono::system_clock::time_point;

// One emergency message as the status keeps it (the family's decoded text).
struct EmcyRecord {
  std::uint16_t code = 0;
  std::string text;
  WallTime at{};
};
inline constexpr std::size_t kEmcyHistory = 8;  // the most recent EMCYs kept per device

// The device's last values as the outputs received them (filled in by the
// daemon from the output pipeline, like the hot-path counters of BusStatus).
struct LiveValues {
  bool present = false;          // a TPDO with a position or speed was seen
  bool has_position = false;
  bool has_speed = false;
  std::int64_t position = 0;     // counts, after the device's scaling
  double position_eng = 0;       // in `unit`, as the outputs publish it
  std::string unit;              // "deg" or "counts"
  std::int32_t speed = 0;        // device units (0x6030)
  double age_s = -1;             // since the last value was received; < 0 = never
  WallTime at{};                 // when it was received
  bool stale = false;            // as SCADA and DDS see it (the outputs' stale flag)
  double heartbeat_age_s = -1;   // since the last heartbeat; < 0 = none seen
  ArrivalHistogram heartbeat_intervals;  // between two heartbeats, as the outputs received them
  ArrivalHistogram tpdo_intervals;       // between two TPDOs
};

// An object the configuration sets that a client wrote to another value
// (bus/config_drift.hpp); open until the configured value is back.
struct DriftRecord {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::string object;              // "0x1017:00"
  std::string name;                // the configuration's name for it: "heartbeat_ms"; may be empty
  std::uint32_t configured = 0;    // the configured bits (owned bits only)
  std::uint32_t owned = 0xFFFFFFFFu;  // the bits the configuration sets
  std::uint32_t value = 0;         // as the client wrote it
  std::string writer;              // "uid 0 pid 42 (control socket)", "309-3 10.0.0.5:4711", "plugin modbus"
  WallTime at{};
  // Restores of this object within the last 10 minutes (bus/restore_guard.hpp).
  unsigned restores = 0;
  // Written back 3 times and changed again: the gateway writes and stores it
  // no more until an operator acknowledges (`cobridge acknowledge DEVICE`).
  bool contested = false;
};

struct DeviceStatus {
  std::string name;            // configured name, or "unknown-<serial>"
  std::string bus;
  std::uint8_t node_id = 0;    // 0 = none yet
  canopen::LssAddress identity;
  std::string model;           // EDS ProductName
  std::string family;          // EDS [Cobridge] Family
  DeviceState state = DeviceState::expected;
  canopen::NmtState nmt = canopen::NmtState::boot_up;
  bool online = false;
  WallTime since{};            // when `state` was entered
  std::string last_error;      // empty = none
  std::uint16_t last_emcy_code = 0;
  std::string last_emcy_text;
  std::uint32_t boot_ups = 0;
  std::uint32_t configurations = 0;   // plans run (with writes)
  std::uint32_t emcy_count = 0;
  std::string fingerprint;            // of the applied configuration
  // LSS commissioning: tries that failed so far (the cause is in
  // last_error), and when the next one is due ({} = none scheduled).
  std::uint32_t commission_failures = 0;
  WallTime next_retry{};
  std::vector<EmcyRecord> emcy_history;  // most recent last, at most kEmcyHistory
  DeviceTimeline timeline;               // most recent last, at most kTimelineLength (shared by copies)
  // Objects a client set away from the configuration ("configuration
  // differs" while not empty); cleared by the next successful plan.
  std::vector<DriftRecord> drift;
  LiveValues values;
};

// Its drift records the gateway no longer writes back (DriftRecord::contested).
[[nodiscard]] inline std::size_t contested_count(const DeviceStatus& d) {
  std::size_t n = 0;
  for (const auto& r : d.drift) n += r.contested ? 1U : 0U;
  return n;
}

// How long a commissioning or configuration step took (reported by status).
struct StepTiming {
  std::string step;   // "fastscan", "slowscan", "switch-selective", "configure <name>", ...
  std::string device;
  double milliseconds = 0;
  std::uint32_t exchanges = 0;  // LSS steps: request/answer exchanges
  std::uint32_t timeouts = 0;   // LSS steps: exchanges that waited out a timeout
  std::uint32_t restarts = 0;   // Fastscan: begun again after a failed confirm (late answers)
  WallTime at{};
};

// The bus's flight recorder (docs/operations.md "Flight recorder").
struct RecorderStatus {
  bool on = false;                // recorder_seconds > 0 and its captures directory usable
  std::uint32_t seconds = 0;      // the window kept in memory
  std::size_t capacity = 0;       // frames the ring holds
  std::uint64_t memory_bytes = 0; // what the ring takes
  std::uint64_t recorded = 0;     // frames recorded since start
  std::size_t pending = 0;        // captures waiting for their window to close
  std::string dir;                // where the captures are
  std::vector<CaptureInfo> captures;  // on disk, oldest first
  std::uint32_t budget_per_hour = 0;      // capture_budget_per_hour
  std::uint64_t skipped_over_budget = 0;  // captures not made since start: the hour's budget was used up
};

struct BusStatus {
  std::string name;
  std::string interface;
  bool open = false;
  std::uint16_t bitrate_kbit = 0;     // the configured bit rate (the page's bus load)
  std::string last_bus_event;         // e.g. "bus-off", "interface down"
  can::ControllerHealth controller;   // fault confinement state and counters, from error frames
  std::uint64_t rx_frames = 0;
  std::uint64_t tx_frames = 0;
  std::uint64_t rx_overflow_drops = 0;
  std::uint64_t error_frames = 0;
  std::uint32_t reopens = 0;
  // The hot path's counters (filled in by the daemon from the output pipeline).
  std::uint64_t unknown_node_frames = 0;  // frames of nodes no device index belongs to: counted, not published
  std::uint64_t ring_drops = 0;           // samples lost because the bus's ring was full
  std::uint64_t hot_rx_frames = 0;        // frames the hot path's socket received
  std::uint64_t hot_kernel_drops = 0;     // frames the kernel dropped at the hot path's socket (SO_RXQ_OVFL)
  std::uint64_t status_drops = 0;         // status events lost (the bus's control ring full)
  std::uint64_t bad_length_frames = 0;    // PDO/EMCY/heartbeat of the wrong length: not published
  std::uint64_t tx_dropped = 0;           // frames the control socket could not send (ENOBUFS after back-off)
  // [redundancy] only (role empty without it: this gateway is the only master).
  std::string role;                   // master, standby, starting, negotiating, claiming
  std::uint8_t master_node = 0;       // the bus's master gateway, 0 = none known
  std::uint8_t peer_node = 0;         // the other gateway heard on the bus, 0 = none yet
  std::string election_cause;         // why the role is what it is
  WallTime election_at{};             // when the role last changed
  std::vector<DeviceStatus> devices;
  std::vector<StepTiming> steps;      // most recent last, bounded
  std::vector<std::string> problems;  // unknown serial, clash, wrong model, ...
  RecorderStatus recorder;
};

}  // namespace cobridge::bus
