// FrameDecoder: one bus's CAN frames -> samples, on the bus's RX thread.
//
// TPDO1/TPDO2 (0x181..0x2FF) are decoded with the device's DecodePlan into
// position, speed, CAM, work-area, alarm, warning, temperature and voltage;
// EMCY (0x081..0x0FF) and heartbeat/boot-up (0x701..0x77F) become samples of
// their own kinds; SYNC (0x080) only updates the counter that synchronous
// TPDOs are stamped with. Every sample of a device gets the next sequence
// number, so a gap downstream proves a loss; and the next number of its kind
// (kind_sequence), so a gap in one kind proves a loss of that kind.
//
// Per frame: no allocation, no lock, no exception, no logging; problems are
// counted (stats()). refresh() is called once per receive batch, after the
// batch was read and before it is decoded: a plan published before a frame
// was sent is in effect for that frame. It costs one atomic load unless a
// plan changed.
// Thread: the bus's RX thread only (stats() may be read from any thread).
#pragma once

#include "can/frame.hpp"
#include "pipeline/device_table.hpp"
#include "pipeline/sample.hpp"

#include <array>
#include <atomic>
#include <cstdint>

namespace cobridge::pipeline {

struct DecoderStats {
  std::uint64_t frames = 0;         // frames looked at
  std::uint64_t samples = 0;        // samples produced
  std::uint64_t unknown_node = 0;   // frame of a node no device index belongs to (or a PDO without an active plan)
  std::uint64_t bad_length = 0;     // PDO shorter than its mapping, EMCY/heartbeat of the wrong length
  std::uint64_t ignored = 0;        // other COB-IDs (SDO, LSS, NMT, ... that a recorder's socket passes): not errors
};

class FrameDecoder {
 public:
  FrameDecoder(std::uint8_t bus_index, const DeviceTable& table);

  // Picks up new plans if the control thread published any.
  void refresh();
  // The two clocks as read once per receive batch: frames carry kernel
  // CLOCK_REALTIME stamps; samples also get them on CLOCK_MONOTONIC, and
  // staleness is judged on it, so a wall-clock step never marks good data
  // stale or stale data fresh.
  void set_clocks(std::int64_t realtime_ns, std::int64_t monotonic_ns) noexcept {
    mono_minus_real_ = monotonic_ns - realtime_ns;
  }

  // Returns true and fills `out` when the frame produced a sample.
  bool decode(const can::Frame& frame, Sample& out) noexcept;

  // A STATUS sample (online / stale / NMT state as the gateway sees it).
  bool make_status(std::uint8_t node_id, bool online, bool stale, std::uint8_t nmt_state,
                   std::int64_t timestamp_ns, Sample& out) noexcept;

  // A COMMAND sample: the outcome of a command a plugin submitted (ABI 2).
  bool make_command(std::uint8_t node_id, std::uint8_t kind, std::uint8_t status, std::uint32_t tag,
                    std::uint32_t abort_code, std::int64_t timestamp_ns, Sample& out) noexcept;

  // Nodes whose last TPDO is older than their plan's max_age_ms at
  // `now_mono_ns` (CLOCK_MONOTONIC) and not yet reported stale: calls
  // emit(node) once per such change.
  template <typename Emit>
  void check_stale(std::int64_t now_mono_ns, Emit&& emit) noexcept {
    const std::int64_t now_ns = now_mono_ns;
    for (std::size_t n = 1; n < DeviceTable::kNodes; ++n) {
      const DecodePlan& p = plans_[n];
      if (!p.active || p.max_age_ms == 0 || stale_[n] || last_pdo_ns_[n] == 0) continue;
      if (now_ns - last_pdo_ns_[n] > static_cast<std::int64_t>(p.max_age_ms) * 1'000'000) {
        stale_[n] = true;
        emit(static_cast<std::uint8_t>(n));
      }
    }
  }

  [[nodiscard]] DecoderStats stats() const noexcept;
  [[nodiscard]] const DecodePlan& plan(std::uint8_t node_id) const noexcept { return plans_[node_id]; }

 private:
  bool decode_tpdo(const can::Frame& f, std::uint8_t node, std::size_t pdo, Sample& out) noexcept;
  void header(const can::Frame& f, std::uint8_t node, std::uint8_t kind, Sample& out) noexcept;
  // The header of a sample the gateway makes itself (status, command outcome).
  bool gateway_header(std::uint8_t node, std::uint8_t kind, std::int64_t timestamp_ns, Sample& out) noexcept;
  // True when the node has a device index; otherwise counts the frame as unknown_node.
  bool indexed(std::uint8_t node) noexcept;
  void count(std::atomic<std::uint64_t>& c) noexcept { c.store(c.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed); }

  const std::uint8_t bus_index_;
  const DeviceTable& table_;
  DeviceTable::Plans plans_{};
  std::uint32_t generation_ = 0;
  bool synced_ = false;
  std::array<std::uint32_t, DeviceTable::kNodes> sequence_{};
  // Per node and sample kind (COBRIDGE_SAMPLE_*, 1..kKinds-1).
  static constexpr std::size_t kKinds = 8;
  std::array<std::array<std::uint32_t, kKinds>, DeviceTable::kNodes> kind_sequence_{};
  std::array<std::int64_t, DeviceTable::kNodes> last_pdo_ns_{};  // CLOCK_MONOTONIC
  std::int64_t mono_minus_real_ = 0;
  std::array<bool, DeviceTable::kNodes> stale_{};
  std::uint8_t sync_counter_ = 0;
  // Written by the RX thread only; atomics so another thread may read them.
  std::atomic<std::uint64_t> frames_{0}, samples_{0}, unknown_node_{0}, bad_length_{0}, ignored_{0};
};

}  // namespace cobridge::pipeline
