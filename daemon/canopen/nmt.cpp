#include "canopen/nmt.hpp"

#include "canopen/cob_id.hpp"

namespace cobridge::canopen {

std::string_view to_string(NmtCommand command) noexcept {
  switch (command) {
    case NmtCommand::start: return "start remote node";
    case NmtCommand::stop: return "stop remote node";
    case NmtCommand::enter_preop: return "enter pre-operational";
    case NmtCommand::reset_node: return "reset node";
    case NmtCommand::reset_comm: return "reset communication";
  }
  return "unknown NMT command";
}

std::string_view to_string(NmtState state) noexcept {
  switch (state) {
    case NmtState::boot_up: return "boot-up";
    case NmtState::stopped: return "stopped";
    case NmtState::operational: return "operational";
    case NmtState::pre_operational: return "pre-operational";
  }
  return "unknown NMT state";
}

std::string_view to_string(NmtFrameError error) noexcept {
  switch (error) {
    case NmtFrameError::none: return "ok";
    case NmtFrameError::wrong_cob_id: return "wrong COB-ID";
    case NmtFrameError::wrong_length: return "wrong data length";
    case NmtFrameError::remote_request: return "unexpected remote request";
    case NmtFrameError::extended_id: return "29-bit identifier";
    case NmtFrameError::unknown_command: return "unknown NMT command specifier";
    case NmtFrameError::unknown_state: return "unknown NMT state";
    case NmtFrameError::invalid_node: return "invalid node-ID";
  }
  return "unknown error";
}

bool is_nmt_command(uint8_t value) noexcept {
  switch (value) {
    case 0x01: case 0x02: case 0x80: case 0x81: case 0x82: return true;
    default: return false;
  }
}

bool is_nmt_state(uint8_t value) noexcept {
  switch (value) {
    case 0x00: case 0x04: case 0x05: case 0x7F: return true;
    default: return false;
  }
}

can::Frame make_nmt(NmtCommand command, uint8_t node) noexcept {
  return can::Frame::make(cob::kNmt, {static_cast<uint8_t>(command), node});
}

NmtCommandParse parse_nmt(const can::Frame& frame) noexcept {
  NmtCommandParse r;
  if (frame.is_extended()) {
    r.error = NmtFrameError::extended_id;
  } else if (frame.id != cob::kNmt) {
    r.error = NmtFrameError::wrong_cob_id;
  } else if (frame.is_rtr()) {
    r.error = NmtFrameError::remote_request;
  } else if (frame.len != 2) {
    r.error = NmtFrameError::wrong_length;
  } else if (!is_nmt_command(frame.data[0])) {
    r.error = NmtFrameError::unknown_command;
  } else if (frame.data[1] > cob::kNodeIdMax) {
    r.error = NmtFrameError::invalid_node;
  } else {
    r.frame.command = static_cast<NmtCommand>(frame.data[0]);
    r.frame.node = frame.data[1];
  }
  return r;
}

namespace {

// The node-ID of an 11-bit frame on 0x700 + 1..127, or 0 if it is not one.
uint8_t error_control_node(const can::Frame& frame) noexcept {
  if (frame.is_extended() || frame.id < cob::kNmtErrorControlBase + cob::kNodeIdMin ||
      frame.id > cob::kNmtErrorControlBase + cob::kNodeIdMax)
    return 0;
  return static_cast<uint8_t>(frame.id - cob::kNmtErrorControlBase);
}

}  // namespace

ErrorControlParse parse_error_control(const can::Frame& frame) noexcept {
  ErrorControlParse r;
  if (frame.is_extended()) {
    r.error = NmtFrameError::extended_id;
    return r;
  }
  if ((frame.id & ~uint32_t{0x7F}) != cob::kNmtErrorControlBase) {
    r.error = NmtFrameError::wrong_cob_id;
    return r;
  }
  const uint8_t node = error_control_node(frame);
  if (node == 0) {
    r.error = NmtFrameError::invalid_node;
  } else if (frame.is_rtr()) {
    r.error = NmtFrameError::remote_request;
  } else if (frame.len != 1) {
    r.error = NmtFrameError::wrong_length;
  } else if (!is_nmt_state(static_cast<uint8_t>(frame.data[0] & 0x7F))) {
    r.error = NmtFrameError::unknown_state;
  } else {
    r.message.node = node;
    r.message.state = static_cast<NmtState>(frame.data[0] & 0x7F);
    r.message.toggle = (frame.data[0] & 0x80) != 0;
    r.message.is_boot_up = frame.data[0] == 0x00;
  }
  return r;
}

can::Frame make_guard_request(uint8_t node) noexcept {
  can::Frame f;
  f.id = cob::kNmtErrorControlBase + node;
  f.len = 1;
  f.flags = can::Frame::kFlagRtr;
  return f;
}

bool is_guard_request(const can::Frame& frame, uint8_t& node) noexcept {
  if (!frame.is_rtr()) return false;
  const uint8_t n = error_control_node(frame);
  if (n == 0) return false;
  node = n;
  return true;
}

can::Frame make_boot_up(uint8_t node) noexcept {
  return can::Frame::make(cob::kNmtErrorControlBase + node, {0x00});
}

can::Frame make_heartbeat(uint8_t node, NmtState state) noexcept {
  return can::Frame::make(cob::kNmtErrorControlBase + node, {static_cast<uint8_t>(state)});
}

can::Frame make_guard_reply(uint8_t node, NmtState state, bool toggle) noexcept {
  const auto byte = static_cast<uint8_t>(static_cast<uint8_t>(state) | (toggle ? 0x80 : 0x00));
  return can::Frame::make(cob::kNmtErrorControlBase + node, {byte});
}

// ---------------------------------------------------------------------------
// NmtSlaveState

NmtTransition NmtSlaveState::complete_initialisation() noexcept {
  const NmtState from = state_;
  if (state_ != NmtState::boot_up) return {NmtOutcome::ignored, from, state_};
  state_ = autostart_ ? NmtState::operational : NmtState::pre_operational;
  return {NmtOutcome::state_changed, from, state_};
}

NmtTransition NmtSlaveState::apply(NmtCommand command) noexcept {
  const NmtState from = state_;
  // In initialisation the NMT slave is not yet listening (CiA 301 §7.3.2.2.1).
  if (state_ == NmtState::boot_up) return {NmtOutcome::ignored, from, from};

  NmtState target = state_;
  switch (command) {
    case NmtCommand::start: target = NmtState::operational; break;
    case NmtCommand::stop: target = NmtState::stopped; break;
    case NmtCommand::enter_preop: target = NmtState::pre_operational; break;
    // Both resets go through initialisation; the owner decides which
    // parameters to reset and then completes the initialisation.
    case NmtCommand::reset_node:
      state_ = NmtState::boot_up;
      return {NmtOutcome::reset_node, from, state_};
    case NmtCommand::reset_comm:
      state_ = NmtState::boot_up;
      return {NmtOutcome::reset_communication, from, state_};
  }
  if (target == state_) return {NmtOutcome::unchanged, from, from};
  state_ = target;
  return {NmtOutcome::state_changed, from, target};
}

NmtTransition NmtSlaveState::on_frame(const can::Frame& frame, uint8_t own_node) noexcept {
  const NmtCommandParse p = parse_nmt(frame);
  if (!p.ok() || !p.frame.addresses(own_node)) return {NmtOutcome::ignored, state_, state_};
  return apply(p.frame.command);
}

NmtTransition NmtSlaveState::apply_error_behaviour(uint8_t value) noexcept {
  const NmtState from = state_;
  switch (value) {
    case 0:
      if (state_ == NmtState::operational) {
        state_ = NmtState::pre_operational;
        return {NmtOutcome::state_changed, from, state_};
      }
      break;
    case 2:
      if (state_ == NmtState::pre_operational || state_ == NmtState::operational) {
        state_ = NmtState::stopped;
        return {NmtOutcome::state_changed, from, state_};
      }
      break;
    default:
      break;  // 1 = no change; other values are reserved and change nothing
  }
  return {NmtOutcome::unchanged, from, from};
}

bool NmtSlaveState::allows(NmtService service) const noexcept {
  switch (state_) {
    case NmtState::boot_up:
      return service == NmtService::boot_up;
    case NmtState::pre_operational:
      return service != NmtService::pdo && service != NmtService::boot_up;
    case NmtState::operational:
      return service != NmtService::boot_up;
    case NmtState::stopped:
      return service == NmtService::nmt || service == NmtService::error_control;
  }
  return false;
}

}  // namespace cobridge::canopen
