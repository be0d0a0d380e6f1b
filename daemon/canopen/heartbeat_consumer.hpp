// HeartbeatConsumer: watches the heartbeats of up to 127 nodes (CiA 301
// §7.2.8.3.2.2, consumer side; object 0x1016 on a device).
//
// Each monitored node has a consumer time. Monitoring of a node is armed by
// its first heartbeat (CiA 301 0x1016: "monitoring starts after the reception
// of the first heartbeat") and a heartbeat event ("node lost") is reported
// when the next one does not arrive within the consumer time. A boot-up
// message is reported and disarms monitoring again until the node's next
// heartbeat: after a reset the node's producer time may not be configured
// yet, and the owner reconfigures it in reaction to the boot-up.
//
// Thread: one thread (the bus thread of the gateway) calls on_frame() and
// process(); the class holds no locks. Storage is fixed (one slot per
// node-ID); neither call allocates. The callback is set once at setup and is
// called synchronously from on_frame()/process(); it must not block or throw.
#pragma once

#include <array>
#include <cstdint>
#include <functional>

#include "can/frame.hpp"
#include "canopen/clock.hpp"
#include "canopen/nmt.hpp"

namespace cobridge::canopen {

// One 0x1016 sub-entry (CiA 301 §7.5.2.33; F§7.3 0x1016/1): bits 23-16 the
// node to watch, bits 15-0 the consumer time in ms, 0 = entry unused.
struct ConsumerHeartbeatEntry {
  uint8_t node = 0;
  uint16_t time_ms = 0;
  [[nodiscard]] static constexpr ConsumerHeartbeatEntry from_raw(uint32_t raw) noexcept {
    return {static_cast<uint8_t>((raw >> 16) & 0xFF), static_cast<uint16_t>(raw & 0xFFFF)};
  }
  [[nodiscard]] constexpr uint32_t raw() const noexcept {
    return (uint32_t{node} << 16) | time_ms;
  }
};

class HeartbeatConsumer {
 public:
  enum class EventKind : uint8_t {
    boot_up,        // boot-up message seen (the node has reset)
    state_changed,  // heartbeat with a different state (also the first heartbeat)
    timeout,        // heartbeat event: no heartbeat within the consumer time
    recovered,      // a heartbeat after a timeout
  };
  struct Event {
    EventKind kind = EventKind::boot_up;
    uint8_t node = 0;
    NmtState state = NmtState::boot_up;     // last known state
    NmtState previous = NmtState::boot_up;  // valid if previous_known
    bool previous_known = false;
    TimePoint time{};  // when it was detected (for timeout: the deadline that passed)
  };
  using Callback = std::function<void(const Event&)>;

  struct NodeStatus {
    bool configured = false;
    bool armed = false;      // a heartbeat has been seen since configure / boot-up
    bool timed_out = false;
    bool state_known = false;
    NmtState state = NmtState::boot_up;
    Duration consumer_time{};
    TimePoint last_seen{};
  };

  void set_callback(Callback callback) { callback_ = std::move(callback); }

  // Start (or change) monitoring of `node`; a zero or negative time stops it,
  // as 0 does in 0x1016. Returns false for node-IDs outside 1..127.
  bool configure(uint8_t node, Duration consumer_time) noexcept;
  void remove(uint8_t node) noexcept;
  // The node's next state is reported as a change (state_changed with
  // previous_known false) even when it equals the last one: the master
  // discounted that one and needs to hear whether it persists.
  void forget_state(uint8_t node) noexcept;
  // The node confirmed a write of its producer heartbeat time (0x1017) at
  // `at`: a producer starts its period over with the new time, so one gap
  // of up to a period plus the time since its last heartbeat is no loss.
  // The deadline of an armed consumer that has not timed out counts from
  // `at` (the confirmation is itself a sign of life).
  void restart_period(uint8_t node, TimePoint at) noexcept;

  // Feed every received frame. Returns true if it was a boot-up or heartbeat
  // of a monitored node.
  bool on_frame(const can::Frame& frame, TimePoint now) noexcept;

  // Report timeouts due at `now`; returns the earliest pending deadline.
  TimePoint process(TimePoint now) noexcept;

  [[nodiscard]] NodeStatus status(uint8_t node) const noexcept;

 private:
  void emit(EventKind kind, uint8_t node, NmtState state, bool previous_known,
            NmtState previous, TimePoint time) const noexcept;

  std::array<NodeStatus, 128> nodes_{};  // indexed by node-ID; slot 0 unused
  Callback callback_;
};

}  // namespace cobridge::canopen
