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
    case ElectionCause::claim_unbacked: return "the gateway that claimed the role sent no master heartbeat";
  }
  return "?";
}

void MasterElection::start(TimePoint now, can::FrameSink& out) noexcept {
  role_ = MasterRole::starting;
  master_node_ = 0;
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
  backed_ = false;
  deadline_ = now + config_.priority * kPrioritySlot + config_.node_id * kNodeSlot;
  // Back from a claim nobody backed (its silence, or a 0x72 meanwhile): the
  // negotiation it interrupted goes on where it was, so a forged claim costs
  // at most 1.5 periods, not a new wait (measured before: 1132 ms without a
  // master after a preempt).
  if (resume_at_ != kNever) deadline_ = std::max(now, resume_at_);
  resume_at_ = kNever;
  change(MasterRole::negotiating, cause, now);
}

// Every claim is preceded by this gateway's announcement, so that the others
// know it as a gateway (and its priority) before they weigh the claim.
void MasterElection::send_claim(can::FrameSink& out) noexcept {
  (void)out.send(can::Frame::make(cob::kMasterResponse, {config_.priority, config_.node_id}));
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

// Standby behind `node`, which is master only once its heartbeat says 05h
// (backed_); master_seen_ gives it 1.5 periods to say so.
void MasterElection::follow(uint8_t priority, uint8_t node, ElectionCause cause, TimePoint now) noexcept {
  // The negotiation left stays owed until the followed master's heartbeat
  // backs it (also when a second claim takes over from an unbacked one).
  if (role_ == MasterRole::negotiating) {
    resume_at_ = deadline_;
  } else if (role_ != MasterRole::standby || backed_) {
    resume_at_ = kNever;
  }
  if (role_ != MasterRole::standby || node != master_node_) {
    next_preempt_ = now + config_.hold;  // the hold time runs from here, for this master
    backed_ = false;
  }
  master_node_ = node;
  master_priority_ = priority;
  master_seen_ = now;
  deadline_ = kNever;
  handover_pending_ = false;
  change(MasterRole::standby, cause, now);
}

void MasterElection::on_claim_frame(const can::Frame& frame, TimePoint now, can::FrameSink& out) noexcept {
  if (frame.len < 2) return;
  const uint8_t priority = frame.data[0];
  const uint8_t node = frame.data[1];
  // A gateway claims with the priority it announced: a claim that says
  // otherwise is not its own.
  if (!peers_.plausible(priority, node) || !peers_.as_announced(priority, node)) {
    ++counters_.claims_ignored;
    return;
  }
  on_claim(priority, node, now, out);
}

// Two claims at once, or two masters after a healed split: the rank decides,
// and the one that keeps the role says so again. Only a live gateway that
// announced itself takes the role from us; another's claim is not answered
// (no exchange of claims with a stranger).
void MasterElection::on_claim_as_master(uint8_t priority, uint8_t node, TimePoint now, can::FrameSink& out) noexcept {
  if (!live_peer(priority, node, now)) {
    ++counters_.claims_ignored;
  } else if (outranks_us(priority, node)) {
    follow(priority, node, ElectionCause::better_claim, now);
  } else {
    send_claim(out);
  }
}

void MasterElection::on_claim(uint8_t priority, uint8_t node, TimePoint now, can::FrameSink& out) noexcept {
  const bool announced = peers_.announced(node);
  switch (role_) {
    case MasterRole::starting:
      follow(priority, node, ElectionCause::master_answered, now);
      break;
    case MasterRole::negotiating:
      // The first claim ends every wait, but the rank decides: one node-ID
      // is 2 ms of slot, less than a late wake-up, so a gateway that
      // outranks a live claimant claims at once and the claimant yields in
      // its settle time (on_claim_as_master).
      if (live_peer(priority, node, now) && !outranks_us(priority, node)) {
        // Our heartbeat first: a claimant yields only to a live peer, and a
        // late wake-up may have kept ours off the bus for a while.
        send_heartbeat(out);
        claim(now, out);
      } else {
        follow(priority, node, ElectionCause::claimed, now);
      }
      break;
    case MasterRole::claiming:
    case MasterRole::master:
      on_claim_as_master(priority, node, now, out);
      break;
    case MasterRole::standby:
      // The master's claims do not keep it alive (its heartbeat does), and
      // another's claim does not replace a master whose heartbeat we hear,
      // unless we only heard ours (it never announced itself) and this one
      // did.
      if (node != master_node_ && announced && !peers_.announced(master_node_)) {
        follow(priority, node, ElectionCause::claimed, now);
      }
      break;
  }
}

void MasterElection::on_announce(const can::Frame& frame, TimePoint now) noexcept {
  if (frame.len < 2 || !peers_.on_announce(frame.data[0], frame.data[1], now, master_timeout())) {
    ++counters_.claims_ignored;
  }
}

// A gateway's heartbeat (0x700 + node-ID): the followed master is alive
// while it says 05h.
bool MasterElection::on_heartbeat(const can::Frame& frame, TimePoint now) noexcept {
  if (frame.id <= cob::kNmtErrorControlBase || frame.id > cob::kNmtErrorControlBase + 127 || frame.len < 1) {
    return false;
  }
  const auto node = static_cast<uint8_t>(frame.id - cob::kNmtErrorControlBase);
  if (node == config_.node_id) return false;
  // Any node's: a gateway's claim may come before we know it as one (its
  // announcement and claim together, after a healed bus split).
  peers_.heard(node, now);
  if (!is_gateway(node)) return false;
  if (role_ == MasterRole::standby && node == master_node_ && (frame.data[0] & 0x7F) == kStateOperational) {
    master_seen_ = now;
    backed_ = true;
    resume_at_ = kNever;
  }
  return true;
}

// Only a live peer of higher rank asks for the role (its preempt), and a
// master hands it over at most once per hold-down (measured: a 0x76 storm
// made 49 handovers in 20 s).
void MasterElection::on_force(const can::Frame& frame, TimePoint now, can::FrameSink& out) noexcept {
  if (role_ != MasterRole::master || handover_pending_) return;
  const bool from_peer = frame.len >= 2 && live_peer(frame.data[0], frame.data[1], now) &&
                         outranks_us(frame.data[0], frame.data[1]);
  if (!from_peer) {
    ++counters_.forces_ignored;
    return;
  }
  if (last_handover_ != kNever && now - last_handover_ < kHandoverHoldDown) {
    ++counters_.forces_held;
    return;
  }
  handover_pending_ = true;
  if (busy_) return;  // handed over by process() once idle
  hand_over(now, out);
}

void MasterElection::hand_over(TimePoint now, can::FrameSink& out) noexcept {
  last_handover_ = now;
  (void)out.send(can::Frame::make(cob::kFlyingMasterRequest, {}));
  negotiate(ElectionCause::preempted, now);
}

bool MasterElection::owns(const can::Frame& frame) const noexcept {
  if (frame.is_extended() || frame.is_rtr()) return false;
  if (frame.id >= cob::kMasterNodeId && frame.id <= cob::kForceNegotiation) return true;
  return frame.id > cob::kNmtErrorControlBase && frame.id <= cob::kNmtErrorControlBase + 127 &&
         is_gateway(static_cast<uint8_t>(frame.id - cob::kNmtErrorControlBase));
}

bool MasterElection::on_frame(const can::Frame& frame, TimePoint now, can::FrameSink& out) noexcept {
  if (frame.is_extended() || frame.is_rtr()) return false;
  switch (frame.id) {
    case cob::kMasterNodeId:
      on_claim_frame(frame, now, out);
      return true;
    case cob::kMasterResponse:
      on_announce(frame, now);
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
      on_force(frame, now, out);
      return true;
    default:
      break;
  }
  return on_heartbeat(frame, now);
}

TimePoint MasterElection::step_master(TimePoint now, can::FrameSink& out) noexcept {
  if (!handover_pending_ || busy_) return kNever;
  hand_over(now, out);
  return deadline_;
}

TimePoint MasterElection::step_standby(TimePoint now, can::FrameSink& out) noexcept {
  if (now - master_seen_ >= master_timeout()) {
    (void)out.send(can::Frame::make(cob::kFlyingMasterRequest, {}));
    negotiate(backed_ ? ElectionCause::master_lost : ElectionCause::claim_unbacked, now);
    return deadline_;
  }
  const TimePoint lost_at = master_seen_ + master_timeout();
  if (!config_.preempt || outranks_us(master_priority_, master_node_) || !backed_) return lost_at;
  // Asked again every hold time: the master may hold the role down.
  if (now < next_preempt_) return std::min(lost_at, next_preempt_);
  (void)out.send(can::Frame::make(cob::kForceNegotiation, {config_.priority, config_.node_id}));
  next_preempt_ = now + config_.hold;
  return std::min(lost_at, next_preempt_);
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
      return step_master(now, out);
    case MasterRole::standby:
      break;
  }
  return step_standby(now, out);
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
