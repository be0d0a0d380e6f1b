// Supervisor: watches the configured devices of one bus and turns what it
// sees into changes of their DeviceStatus: heartbeat consumer (CiA 301
// §7.2.8.3.2.2) or node guarding master (§7.2.8.3.2.1) per device, boot-up
// messages (§7.2.8.3.3), and EMCY (§7.2.7) decoded with the device family's
// table (device::describe_emcy: the family module's rows, else CiA 301).
//
// It wraps canopen::HeartbeatConsumer and canopen::NodeGuardMaster and adds
// what they leave to the owner: a device that never sends its first heartbeat
// after being started is reported too (the consumer only arms on the first
// one), and each transition is reported once as a Change with a reason.
// Reacting (reconfiguring a device that rebooted) is the bus manager's job.
//
// Thread: the bus manager's control thread calls everything; no locks, no
// clock (now is passed in), fixed per-node storage. EMCY text is built on
// the control thread (it allocates), never on the hot path.
#pragma once

#include "can/frame.hpp"
#include "can/frame_sink.hpp"
#include "canopen/clock.hpp"
#include "canopen/emcy.hpp"
#include "canopen/heartbeat_consumer.hpp"
#include "canopen/nmt.hpp"
#include "canopen/node_guard.hpp"
#include "families/family.hpp"
#include "bus/device_status.hpp"

#include <array>
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace cobridge::bus {

// How a device is watched, from its configuration.
struct Supervision {
  enum class Mode : std::uint8_t { none, heartbeat, guarding };
  Mode mode = Mode::none;
  std::chrono::milliseconds producer_time{0};  // heartbeat: the device's 0x1017
  std::chrono::milliseconds guard_time{0};     // guarding: 0x100C
  std::uint8_t life_time_factor = 0;           // guarding: 0x100D
};

// The consumer time for a producer time: 1.5 x producer + margin, so one late
// heartbeat (bus load, a busy device) is not a loss but two missed ones are.
[[nodiscard]] std::chrono::milliseconds consumer_time_for(std::chrono::milliseconds producer) noexcept;
inline constexpr std::chrono::milliseconds kConsumerMargin{50};

class Supervisor {
 public:
  enum class ChangeKind : std::uint8_t {
    online,      // heartbeat / guarding reply seen (first one, or after a loss)
    offline,     // heartbeat lost / guarding lost / never heard after start
    rebooted,    // boot-up message: the device reset and lost its volatile settings
    nmt_state,   // the device reports another NMT state
    emcy,        // an emergency message
  };
  struct Change {
    ChangeKind kind = ChangeKind::online;
    std::uint8_t node = 0;
    canopen::TimePoint at{};
    canopen::NmtState nmt = canopen::NmtState::boot_up;  // state known at that time
    std::int64_t frame_ns = 0;  // nmt_state: the kernel stamp of the frame that told it (0: none)
    std::string reason;                                   // offline / rebooted / online (the gap)
    std::uint16_t emcy_code = 0;                          // emcy
    std::string emcy_text;                                // emcy: describe(family, emcy)
    bool emcy_reset = false;                              // emcy: "error reset / no error"
  };

  Supervisor();
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  // Start watching `node` (after it was configured and started, at `now`).
  // Replaces an earlier watch of the node.
  void watch(std::uint8_t node, const families::Family* family, const Supervision& supervision,
             canopen::TimePoint now);
  // EMCY and boot-up only (a device being configured: its heartbeat may not
  // run yet). watch() later upgrades it.
  void listen(std::uint8_t node, const families::Family* family);
  void unwatch(std::uint8_t node) noexcept;
  // A client changed the device's heartbeat producer time (0x1017, CiA 301
  // §7.4.8.3) and the gateway keeps it (on_config_drift = "keep"): the
  // consumer follows it from now on, without losing what it heard (0 =
  // the device sends none: no longer watched by heartbeat). Only a node
  // watched by heartbeat; returns whether it was.
  bool follow_producer_time(std::uint8_t node, std::chrono::milliseconds producer_time) noexcept;
  // A client's write of 0x1017 was confirmed at `at`: the producer starts
  // its period over (canopen::HeartbeatConsumer::restart_period); so does
  // the wait for the first heartbeat after a start. Call it after
  // follow_producer_time when the gateway follows the written time.
  void producer_time_written(std::uint8_t node, canopen::TimePoint at) noexcept;
  [[nodiscard]] bool watching(std::uint8_t node) const noexcept;
  [[nodiscard]] bool online(std::uint8_t node) const noexcept;
  // The NMT state its last heartbeat / guarding reply reported (boot_up: none yet).
  [[nodiscard]] canopen::NmtState nmt(std::uint8_t node) const noexcept;
  // The NMT state heard last is set aside as no news (a heartbeat the
  // device sent before it took an NMT command, read after it): the next
  // heartbeat or guarding reply reports its state as a change again.
  void forget_nmt(std::uint8_t node) noexcept;

  // Feed every frame on 0x081..0x0FF and 0x701..0x77F. Returns true when it
  // concerned a node this supervisor knows.
  bool on_frame(const can::Frame& frame, canopen::TimePoint now);
  // The bus is gone (its interface went down or was removed): every watched
  // or online device is reported offline now, with `reason`, instead of one
  // consumer time later; none of its heartbeats can arrive. The watches
  // stay; the first heartbeat after the bus is back reports it online.
  void bus_lost(canopen::TimePoint now, const std::string& reason);
  // Timeouts and guarding requests; returns the next deadline.
  canopen::TimePoint process(canopen::TimePoint now, can::FrameSink& sink);

  // The changes since the previous call, oldest first.
  [[nodiscard]] std::vector<Change> take_changes();

 private:
  // The frames of one node, by kind; true when the frame was the supervisor's.
  bool on_emcy(const can::Frame& frame, std::uint8_t node, canopen::TimePoint now);
  bool on_error_control(const can::Frame& frame, std::uint8_t node, canopen::TimePoint now);
  void on_boot_up(const can::Frame& frame, std::uint8_t node, canopen::TimePoint now);
  struct Node {
    bool known = false;       // listen() or watch()
    bool watched = false;     // supervision running
    const families::Family* family = nullptr;  // nullptr: no family known, CiA 301 texts
    Supervision supervision;
    bool online = false;
    bool heard = false;       // a heartbeat / guarding reply since watch()
    canopen::TimePoint first_deadline = canopen::kNever;  // "never heard" check
    canopen::NmtState nmt = canopen::NmtState::boot_up;
    std::int64_t last_frame_ns = 0;  // the kernel stamp of its last heartbeat / guarding reply
    canopen::TimePoint silent_since = canopen::kNever;  // its last heartbeat before a loss
  };

  // "heartbeat lost: none for 250 ms (consumer time 250 ms, producer time 100 ms)".
  [[nodiscard]] std::string heartbeat_loss_text(std::uint8_t node, canopen::TimePoint detected);
  void on_alive(std::uint8_t node, canopen::NmtState state, canopen::TimePoint at);
  void on_heartbeat_event(const canopen::HeartbeatConsumer::Event& e);
  void on_guard_event(const canopen::NodeGuardMaster::Event& e);
  void set_online(std::uint8_t node, canopen::TimePoint at);
  void set_offline(std::uint8_t node, canopen::TimePoint at, std::string reason);
  void push(Change change);

  std::array<Node, 128> nodes_{};
  canopen::HeartbeatConsumer heartbeat_;
  canopen::NodeGuardMaster guard_;
  std::vector<Change> changes_;
};

// Applies a change to the device's status as the operators see it. `wall` is
// the wall-clock time of the change (for DeviceStatus::since).
void apply(const Supervisor::Change& change, DeviceStatus& device, WallTime wall);

}  // namespace cobridge::bus
