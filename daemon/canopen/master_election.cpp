#include "canopen/master_election.hpp"

#include <algorithm>

#include "canopen/cob_id.hpp"

namespace cobridge::canopen {

namespace {
constexpr uint8_t kStateOperational = 0x05;
constexpr uint8_t kStatePreOperational = 0x7F;
}  // namespace

std::string_view to_string(MasterRole role) noexcept {
  switch (role) {
    case MasterRole::starting: return "starting";
    case MasterRole::negotiating: return "negotiating";
    case MasterRole::claiming: return "claiming";
    case MasterRole::master: return "master";
    case MasterRole::standby: return "standby";
  }
  return "?";
}

std::string_view to_string(ElectionCause cause) noexcept {
  switch (cause) {
    case ElectionCause::master_answered: return "an active master answered";
    case ElectionCause::no_master: return "no active master answered";
    case ElectionCause::master_lost: return "the master's heartbeat stopped";
    case ElectionCause::negotiation_requested: return "another gateway asked for a negotiation";
    case ElectionCause::won: return "our claim held";
    case ElectionCause::claimed: return "another gateway claimed the role first";
    case ElectionCause::better_claim: return "a gateway of higher rank claimed the role";
    case ElectionCause::preempted: return "a gateway of higher rank asked for the role back";
  }
  return "?";
}

void MasterElection::start(TimePoint now, can::FrameSink& out) noexcept {
  role_ = MasterRole::starting;
  master_node_ = 0;
  gateways_[config_.node_id & 0x7F] = true;
  (void)out.send(can::Frame::make(cob::kActiveMasterRequest, {}));
  (void)out.send(can::Frame::make(cob::kMasterResponse, {config_.priority, config_.node_id}));
  // The active master answers at once; a full heartbeat period covers its
  // bus thread's turn and the frames queued before the answer.
  deadline_ = now + master_timeout();
  send_heartbeat(out);
  next_heartbeat_ = now + config_.heartbeat;
}

bool MasterElection::outranks_us(uint8_t priority, uint8_t node) const noexcept {
  return priority < config_.priority || (priority == config_.priority && node < config_.node_id);
}

void MasterElection::change(MasterRole role, ElectionCause cause, TimePoint now) noexcept {
  if (role == role_ && master_node_ == last_.master_node) return;  // nothing new to tell
  last_ = ElectionEvent{role, role_, cause, master_node_, master_priority_, now};
  role_ = role;
  if (callback_) callback_(last_);
}

void MasterElection::negotiate(ElectionCause cause, TimePoint now) noexcept {
  master_node_ = 0;
  master_seen_ = kNever;
  handover_pending_ = false;
  deadline_ = now + config_.priority * kPrioritySlot + config_.node_id * kNodeSlot;
  change(MasterRole::negotiating, cause, now);
}

void MasterElection::send_claim(can::FrameSink& out) noexcept {
  (void)out.send(can::Frame::make(cob::kMasterNodeId, {config_.priority, config_.node_id}));
}

void MasterElection::send_heartbeat(can::FrameSink& out) noexcept {
  const uint8_t state = role_ == MasterRole::master ? kStateOperational : kStatePreOperational;
  (void)out.send(can::Frame::make(cob::kNmtErrorControlBase + config_.node_id, {state}));
}

void MasterElection::claim(TimePoint now, can::FrameSink& out) noexcept {
  send_claim(out);
  deadline_ = now + config_.settle;
  change(MasterRole::claiming, ElectionCause::no_master, now);
}

void MasterElection::follow(uint8_t priority, uint8_t node, ElectionCause cause, TimePoint now) noexcept {
  if (role_ != MasterRole::standby || node != master_node_) {
    standby_since_ = now;  // the hold time runs from here, for this master
    preempt_sent_ = false;
  }
  master_node_ = node;
  master_priority_ = priority;
  master_seen_ = now;
  deadline_ = kNever;
  handover_pending_ = false;
  change(MasterRole::standby, cause, now);
}

void MasterElection::on_claim(uint8_t priority, uint8_t node, TimePoint now, can::FrameSink& out) noexcept {
  switch (role_) {
    case MasterRole::starting:
      follow(priority, node, ElectionCause::master_answered, now);
      break;
    case MasterRole::negotiating:  // the first claim ends every wait
      follow(priority, node, ElectionCause::claimed, now);
      break;
    case MasterRole::claiming:
    case MasterRole::master:
      // Two claims at once, or two masters after a healed split: the rank
      // decides, and the one that keeps the role says so again.
      if (outranks_us(priority, node)) {
        follow(priority, node, ElectionCause::better_claim, now);
      } else {
        send_claim(out);
      }
      break;
    case MasterRole::standby:
      if (node == master_node_) {
        master_seen_ = now;
      } else {
        follow(priority, node, ElectionCause::better_claim, now);
      }
      break;
  }
}

void MasterElection::on_force(TimePoint now, can::FrameSink& out) noexcept {
  if (role_ != MasterRole::master) return;
  handover_pending_ = true;
  if (busy_) return;  // handed over by process() once idle
  (void)out.send(can::Frame::make(cob::kFlyingMasterRequest, {}));
  negotiate(ElectionCause::preempted, now);
}

bool MasterElection::owns(const can::Frame& frame) const noexcept {
  if (frame.is_extended() || frame.is_rtr()) return false;
  if (frame.id >= cob::kMasterNodeId && frame.id <= cob::kForceNegotiation) return true;
  return frame.id > cob::kNmtErrorControlBase && frame.id <= cob::kNmtErrorControlBase + 127 &&
         gateways_[frame.id - cob::kNmtErrorControlBase];
}

uint8_t MasterElection::peer_node() const noexcept {
  for (uint8_t n = 1; n < 128; ++n) {
    if (gateways_[n] && n != config_.node_id) return n;
  }
  return 0;
}

bool MasterElection::on_frame(const can::Frame& frame, TimePoint now, can::FrameSink& out) noexcept {
  if (frame.is_extended() || frame.is_rtr()) return false;
  switch (frame.id) {
    case cob::kMasterNodeId:
      if (frame.len < 2 || frame.data[1] == config_.node_id || frame.data[1] > 127) return true;
      gateways_[frame.data[1]] = true;
      on_claim(frame.data[0], frame.data[1], now, out);
      return true;
    case cob::kMasterResponse:
      if (frame.len >= 2 && frame.data[1] <= 127) gateways_[frame.data[1]] = true;
      return true;
    case cob::kFlyingMasterRequest:
      if (role_ == MasterRole::master) {
        send_claim(out);  // still here: the requester stands by again
      } else if (role_ == MasterRole::standby || role_ == MasterRole::starting) {
        negotiate(ElectionCause::negotiation_requested, now);
      }
      return true;
    case cob::kActiveMasterRequest:
      if (role_ == MasterRole::master) send_claim(out);
      return true;
    case cob::kForceNegotiation:
      on_force(now, out);
      return true;
    default:
      break;
  }
  if (role_ == MasterRole::standby && master_node_ != 0 && frame.id == cob::kNmtErrorControlBase + master_node_) {
    master_seen_ = now;
    return true;
  }
  return false;
}

TimePoint MasterElection::step_role(TimePoint now, can::FrameSink& out) noexcept {
  switch (role_) {
    case MasterRole::starting:
      if (now < deadline_) return deadline_;
      (void)out.send(can::Frame::make(cob::kFlyingMasterRequest, {}));
      negotiate(ElectionCause::no_master, now);
      return deadline_;
    case MasterRole::negotiating:
      if (now < deadline_) return deadline_;
      claim(now, out);
      return deadline_;
    case MasterRole::claiming:
      if (now < deadline_) return deadline_;
      master_node_ = config_.node_id;
      master_priority_ = config_.priority;
      deadline_ = kNever;
      change(MasterRole::master, ElectionCause::won, now);
      send_heartbeat(out);  // the new state on the bus at once
      return kNever;
    case MasterRole::master:
      if (handover_pending_ && !busy_) {
        (void)out.send(can::Frame::make(cob::kFlyingMasterRequest, {}));
        negotiate(ElectionCause::preempted, now);
        return deadline_;
      }
      return kNever;
    case MasterRole::standby:
      break;
  }
  if (now - master_seen_ >= master_timeout()) {
    (void)out.send(can::Frame::make(cob::kFlyingMasterRequest, {}));
    negotiate(ElectionCause::master_lost, now);
    return deadline_;
  }
  if (config_.preempt && !preempt_sent_ && !outranks_us(master_priority_, master_node_)) {
    if (now - standby_since_ >= config_.hold) {
      (void)out.send(can::Frame::make(cob::kForceNegotiation, {}));
      preempt_sent_ = true;
    } else {
      return std::min(master_seen_ + master_timeout(), standby_since_ + config_.hold);
    }
  }
  return master_seen_ + master_timeout();
}

TimePoint MasterElection::process(TimePoint now, can::FrameSink& out) noexcept {
  if (next_heartbeat_ == kNever) return kNever;  // not started
  if (now >= next_heartbeat_) {
    send_heartbeat(out);
    // The master repeats its claim now and then: two masters (the halves of
    // a split bus that meet again) hear each other and the rank decides.
    if (role_ == MasterRole::master && ++beats_ % kAnnounceEvery == 0) send_claim(out);
    next_heartbeat_ += config_.heartbeat;
    if (next_heartbeat_ <= now) next_heartbeat_ = now + config_.heartbeat;  // late: no burst
  }
  const TimePoint role_deadline = step_role(now, out);
  return std::min(role_deadline, next_heartbeat_);
}

}  // namespace cobridge::canopen
