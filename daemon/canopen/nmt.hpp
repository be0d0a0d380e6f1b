// NMT: the CiA 301 network-management commands, the error-control frames
// (boot-up, heartbeat, node-guarding reply) and the slave-side state machine.
//
// The free functions build and parse single frames; they are noexcept and
// allocation-free so they can run on the bus RX thread. `NmtSlaveState` is the
// NMT slave of CiA 301 §7.3.2 (figure "NMT state diagram of a CANopen
// device"); the simulator owns one per simulated node and drives it from its
// own thread. It never sends anything itself: it reports what the owner must
// do (send the boot-up, reset the application or the communication
// parameters), because resetting is the owner's business.
#pragma once

#include <cstdint>
#include <string_view>

#include "can/frame.hpp"

namespace cobridge::canopen {

// CiA 301 §7.2.8.3.1: command specifier in byte 0 of the NMT frame (COB-ID 0).
enum class NmtCommand : uint8_t {
  start = 0x01,
  stop = 0x02,
  enter_preop = 0x80,
  reset_node = 0x81,
  reset_comm = 0x82,
};

// CiA 301 §7.2.8.3.2: state byte of heartbeat / node-guarding replies (bits 0-6).
// `boot_up` (0) is also how this code names the NMT state "initialisation",
// because a node in it can only ever be seen through its boot-up message.
enum class NmtState : uint8_t {
  boot_up = 0x00,
  stopped = 0x04,
  operational = 0x05,
  pre_operational = 0x7F,
};

[[nodiscard]] std::string_view to_string(NmtCommand command) noexcept;
[[nodiscard]] std::string_view to_string(NmtState state) noexcept;
[[nodiscard]] bool is_nmt_command(uint8_t value) noexcept;
[[nodiscard]] bool is_nmt_state(uint8_t value) noexcept;

// Why a frame was not accepted. Per-frame path: an enum, no message strings.
enum class NmtFrameError : uint8_t {
  none = 0,
  wrong_cob_id,       // not the COB-ID of this service
  wrong_length,       // NMT needs DLC 2, error control DLC 1
  remote_request,     // an RTR where a data frame was expected
  extended_id,        // 29-bit identifier: the predefined set is 11-bit
  unknown_command,    // byte 0 is not a CiA 301 command specifier
  unknown_state,      // bits 0-6 are not a CiA 301 state
  invalid_node,       // node-ID outside 1..127 (0 allowed only as "all" in NMT)
};
[[nodiscard]] std::string_view to_string(NmtFrameError error) noexcept;

// `node` 0 addresses all nodes (CiA 301 §7.2.8.3.1).
[[nodiscard]] can::Frame make_nmt(NmtCommand command, uint8_t node) noexcept;

struct NmtCommandFrame {
  NmtCommand command = NmtCommand::start;
  uint8_t node = 0;  // 0 = all nodes
  [[nodiscard]] constexpr bool addresses(uint8_t own_node) const noexcept {
    return node == 0 || node == own_node;
  }
};
struct NmtCommandParse {
  NmtFrameError error = NmtFrameError::none;
  NmtCommandFrame frame;
  [[nodiscard]] constexpr bool ok() const noexcept { return error == NmtFrameError::none; }
};
// The slave's view of a frame on COB-ID 0x000.
[[nodiscard]] NmtCommandParse parse_nmt(const can::Frame& frame) noexcept;

// A boot-up, heartbeat or node-guarding reply on 0x700 + node.
struct ErrorControlMessage {
  uint8_t node = 0;
  NmtState state = NmtState::boot_up;
  bool toggle = false;      // bit 7; meaningful for node-guarding replies only
  bool is_boot_up = false;  // the whole byte is 0x00 (CiA 301 §7.2.8.3.3)
};
struct ErrorControlParse {
  NmtFrameError error = NmtFrameError::none;
  ErrorControlMessage message;
  [[nodiscard]] constexpr bool ok() const noexcept { return error == NmtFrameError::none; }
};
// Rejects RTRs (those are guarding requests: see `is_guard_request`), DLC != 1,
// node-IDs outside 1..127 and state values CiA 301 does not define.
[[nodiscard]] ErrorControlParse parse_error_control(const can::Frame& frame) noexcept;

// A node-guarding remote request on 0x700 + node. DLC 1, because a remote
// frame should carry the DLC of the data frame it asks for.
[[nodiscard]] can::Frame make_guard_request(uint8_t node) noexcept;
// True for an 11-bit RTR on 0x700 + 1..127; sets `node`.
[[nodiscard]] bool is_guard_request(const can::Frame& frame, uint8_t& node) noexcept;

[[nodiscard]] can::Frame make_boot_up(uint8_t node) noexcept;
[[nodiscard]] can::Frame make_heartbeat(uint8_t node, NmtState state) noexcept;
[[nodiscard]] can::Frame make_guard_reply(uint8_t node, NmtState state, bool toggle) noexcept;

// Communication objects and the NMT states in which CiA 301 lets them run
// (CiA 301 §7.3.2.2, table "NMT states and communication objects").
enum class NmtService : uint8_t { pdo, sdo, sync, time, emcy, boot_up, nmt, error_control };

// What the owner of an NmtSlaveState must do after a command.
enum class NmtOutcome : uint8_t {
  ignored,              // not for this node, malformed, or not processed in this state
  unchanged,            // accepted, already in the target state
  state_changed,
  reset_node,           // reset application + communication parameters, then
                        // call complete_initialisation() and send the boot-up
  reset_communication,  // reset communication parameters, then likewise
};

struct NmtTransition {
  NmtOutcome outcome = NmtOutcome::ignored;
  NmtState from = NmtState::boot_up;
  NmtState to = NmtState::boot_up;
};

class NmtSlaveState {
 public:
  // `autostart`: go straight to operational after initialisation, as a
  // Novotechnik device does when 0x1F80 bit 3 is set (J§1.3.1, E§4.1).
  explicit NmtSlaveState(bool autostart = false) noexcept : autostart_(autostart) {}

  [[nodiscard]] NmtState state() const noexcept { return state_; }
  [[nodiscard]] bool initialising() const noexcept { return state_ == NmtState::boot_up; }
  void set_autostart(bool autostart) noexcept { autostart_ = autostart; }

  // Power-on or after a reset outcome: back to initialisation.
  void power_on() noexcept { state_ = NmtState::boot_up; }
  // Initialisation finished: pre-operational, or operational with autostart.
  // The owner sends the boot-up (make_boot_up) when this returns.
  NmtTransition complete_initialisation() noexcept;

  // Apply a command addressed to this node. In initialisation nothing is
  // processed: the node has not joined the network yet.
  NmtTransition apply(NmtCommand command) noexcept;
  // Parse a frame seen on the bus and apply it if it is an NMT command for
  // `own_node` (or broadcast). Other frames return `ignored`.
  NmtTransition on_frame(const can::Frame& frame, uint8_t own_node) noexcept;

  // The CiA 301 §7.2.8.2 error behaviour (object 0x1029): 0 = operational goes
  // to pre-operational, 1 = no change, 2 = stopped. Returns what changed.
  NmtTransition apply_error_behaviour(uint8_t value) noexcept;

  [[nodiscard]] bool allows(NmtService service) const noexcept;

 private:
  NmtState state_ = NmtState::boot_up;
  bool autostart_ = false;
};

}  // namespace cobridge::canopen
