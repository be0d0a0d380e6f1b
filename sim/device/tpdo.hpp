// Tpdo: when one transmit PDO of a simulated encoder goes on the bus.
//
// It owns the timing only: transmission type, SYNC counting, inhibit time,
// event timer, the 1 ms measuring cycle and remote requests. The device
// builds the payload from the mapping (canopen::PdoLayout) whenever
// `due()` says so and reports the transmission with `sent()`.
//
// The families read the CiA 301 transmission types differently, so a
// TpdoPolicy says which reading applies:
//   * type 0: Novotechnik "TPDO off" (J§1.3.1, E§4.1); ifm CiA 301
//     "acyclic synchronous": on the first SYNC after a change (F§7.3);
//   * types 1..240: every n-th SYNC (all);
//   * 252/253: ifm only, RTR (F§7.3); Novotechnik refuses the values;
//   * 254: event timer (Novotechnik, 0 = silent); ifm: on change + timer;
//   * 255: Novotechnik every 1 ms measuring cycle (J§1.2.5, E§3.3); ifm
//     like 254.
// Inhibit time (100 µs units) spaces every asynchronous transmission; a
// synchronous one that falls inside it is skipped (its data would be stale
// by the end of the inhibit time).
// Thread: the device's thread; noexcept, no allocation.
#pragma once

#include <cstdint>

#include "canopen/clock.hpp"

namespace cobridge::sim {

using canopen::Duration;
using canopen::TimePoint;

struct TpdoPolicy {
  bool type0_off = true;            // Novotechnik
  bool type255_every_cycle = true;  // Novotechnik
  bool on_change = false;           // ifm 254/255: a change transmits at once
  bool rtr = false;                 // ifm: answers remote requests if COB-ID bit 30 is clear
};

struct TpdoParams {
  std::uint32_t cob_id = 0x80000000u;  // 0x18xx/1 as written (bit 31 = not valid)
  std::uint8_t type = 254;
  std::uint32_t inhibit_100us = 0;
  std::uint32_t event_ms = 0;
};

class Tpdo {
 public:
  static constexpr std::uint32_t kInvalid = 0x80000000u;
  static constexpr std::uint32_t kNoRtr = 0x40000000u;

  void set_policy(const TpdoPolicy& policy) noexcept { policy_ = policy; }
  // New parameters (a write to 0x18xx or reset). Timers restart at `now`.
  void configure(const TpdoParams& params, TimePoint now) noexcept;
  // Operational on/off: PDOs run only in NMT operational.
  void set_running(bool running, TimePoint now) noexcept;

  [[nodiscard]] bool valid() const noexcept { return (params_.cob_id & kInvalid) == 0; }
  [[nodiscard]] std::uint32_t can_id() const noexcept { return params_.cob_id & 0x7FFu; }
  [[nodiscard]] const TpdoParams& params() const noexcept { return params_; }

  // Inputs.
  void on_sync(TimePoint now) noexcept;
  void on_measure(TimePoint now, bool changed) noexcept;
  // True if the request is for this PDO and will be answered.
  bool on_rtr(TimePoint now) noexcept;

  // Whether a frame should be sent now; then the owner sends and calls sent().
  [[nodiscard]] bool due(TimePoint now) const noexcept;
  void sent(TimePoint now) noexcept;
  // Type 252: the payload is sampled at the SYNC and sent at the RTR.
  [[nodiscard]] bool sample_pending() noexcept;
  [[nodiscard]] bool uses_sampled_data() const noexcept { return params_.type == 252; }

  // Next time due() may become true without an input (kNever if none).
  [[nodiscard]] TimePoint next_deadline() const noexcept;

 private:
  [[nodiscard]] bool active() const noexcept;
  [[nodiscard]] bool is_sync_type() const noexcept { return params_.type >= 1 && params_.type <= 240; }
  [[nodiscard]] bool is_async_type() const noexcept { return params_.type >= 254; }
  [[nodiscard]] Duration inhibit() const noexcept;
  [[nodiscard]] TimePoint inhibit_end() const noexcept;
  void request(TimePoint now) noexcept;

  TpdoPolicy policy_{};
  TpdoParams params_{};
  bool running_ = false;
  bool pending_ = false;      // a transmission was requested and not yet made
  bool changed_ = false;      // type 0: data changed since the last transmission
  bool sample_ = false;       // type 252: SYNC seen, sample the data
  bool have_sent_ = false;
  std::uint8_t sync_count_ = 0;
  TimePoint last_sent_{};
  TimePoint next_event_ = canopen::kNever;
};

}  // namespace cobridge::sim
