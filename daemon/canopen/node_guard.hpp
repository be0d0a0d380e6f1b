// Node guarding (CiA 301 §7.2.8.3.2.1): the master side that polls nodes, and
// the slave side that answers the polls and does life guarding.
//
// NodeGuardMaster: for each guarded node it sends a remote request on
// 0x700 + node every guard time and checks the replies: state in bits 0-6,
// a toggle bit that alternates and starts at 0. A reply whose toggle equals
// the previous one counts as not received (CiA 301). No valid reply within
// the node life time (guard time × life time factor) is the "node guarding
// event" (reported here as `lost`). A boot-up from the node means it passed
// reset communication, so the next reply is expected with toggle 0 again.
//
// GuardResponder: the slave's half, for the simulator. It produces the reply
// to each request with the toggle alternating, and signals the life guarding
// event when no request has come within guard time × life time factor, once
// guarding has started (with the first request).
//
// Thread: each object is driven by one thread (the gateway's bus thread or
// the simulator's); no locks. Frames go out through a can::FrameSink. Fixed
// storage, no allocation per frame; callbacks are set at setup, called
// synchronously, must not block or throw.
#pragma once

#include <array>
#include <cstdint>
#include <functional>

#include "can/frame.hpp"
#include "can/frame_sink.hpp"
#include "canopen/clock.hpp"
#include "canopen/nmt.hpp"

namespace cobridge::canopen {

class NodeGuardMaster {
 public:
  enum class EventKind : uint8_t {
    lost,           // node guarding event: no valid reply within the life time
    recovered,      // a valid reply after `lost`
    toggle_error,   // reply toggle did not alternate; the reply is discarded
    state_changed,  // a valid reply with another state (also the first reply)
    boot_up,        // the node sent a boot-up: toggle expectation reset to 0
  };
  struct Event {
    EventKind kind = EventKind::lost;
    uint8_t node = 0;
    NmtState state = NmtState::boot_up;
    NmtState previous = NmtState::boot_up;
    bool previous_known = false;
    TimePoint time{};
  };
  using Callback = std::function<void(const Event&)>;

  struct NodeStatus {
    bool configured = false;
    bool lost = false;
    bool state_known = false;
    bool expected_toggle = false;  // toggle of the next valid reply
    NmtState state = NmtState::boot_up;
    Duration guard_time{};
    uint8_t life_time_factor = 0;
    TimePoint next_request{};
    TimePoint last_valid{};  // last valid reply, or when guarding started
    uint32_t requests_sent = 0;
    uint32_t send_failures = 0;
  };

  void set_callback(Callback callback) { callback_ = std::move(callback); }

  // Start guarding `node` at `now`: the first request goes out at once. A
  // zero guard time or life time factor disables guarding, as in 0x100C /
  // 0x100D. Returns false for node-IDs outside 1..127.
  bool configure(uint8_t node, Duration guard_time, uint8_t life_time_factor,
                 TimePoint now) noexcept;
  void remove(uint8_t node) noexcept;
  // The node's next state is reported as a change (state_changed with
  // previous_known false) even when it equals the last one: the master
  // discounted that one and needs to hear whether it persists.
  void forget_state(uint8_t node) noexcept;

  // Feed every received frame; true if it was a reply or boot-up of a guarded node.
  bool on_frame(const can::Frame& frame, TimePoint now) noexcept;
  // Send due requests, report life-time expiry; returns the next deadline.
  TimePoint process(TimePoint now, can::FrameSink& sink) noexcept;

  [[nodiscard]] NodeStatus status(uint8_t node) const noexcept;

 private:
  void emit(EventKind kind, uint8_t node, const NodeStatus& n, bool previous_known,
            NmtState previous, TimePoint time) const noexcept;

  std::array<NodeStatus, 128> nodes_{};
  Callback callback_;
};

class GuardResponder {
 public:
  enum class EventKind : uint8_t {
    life_guarding_lost,     // no request within the life time (CiA 301 "life guarding event")
    life_guarding_resumed,  // a request after the loss
  };
  using Callback = std::function<void(EventKind, TimePoint)>;

  void set_callback(Callback callback) { callback_ = std::move(callback); }

  // 0x100C guard time and 0x100D life time factor; either 0 disables life
  // guarding (requests are still answered).
  void configure(Duration guard_time, uint8_t life_time_factor) noexcept;
  // NMT reset communication: the next reply has toggle 0 and life guarding
  // waits for the first request again.
  void reset_communication() noexcept;

  // The reply to a request, with the toggle of this reply; flips the toggle.
  can::Frame reply(uint8_t node, NmtState state, TimePoint now) noexcept;
  // If `frame` is a guarding request for `node`, writes the reply to `out`
  // and returns true.
  bool on_frame(const can::Frame& frame, uint8_t node, NmtState state, TimePoint now,
                can::Frame& out) noexcept;

  // Reports the life guarding event when due; returns the next deadline.
  TimePoint process(TimePoint now) noexcept;

  [[nodiscard]] bool next_toggle() const noexcept { return toggle_; }
  [[nodiscard]] bool active() const noexcept { return active_; }
  [[nodiscard]] bool lost() const noexcept { return lost_; }

 private:
  [[nodiscard]] Duration life_time() const noexcept;

  Duration guard_time_{};
  uint8_t life_time_factor_ = 0;
  bool toggle_ = false;
  bool active_ = false;  // a request has been received since reset communication
  bool lost_ = false;
  TimePoint last_request_{};
  Callback callback_;
};

}  // namespace cobridge::canopen
