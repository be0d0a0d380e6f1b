// MasterElection: which of several gateways on one bus is its NMT master,
// decided on the bus itself, after CiA 302-2's NMT flying master.
//
// The frames (CiA 302-2, identifiers in the NMT range below 0x80):
//   0x71 [priority, node-ID]  "NMT master node-ID": a claim of the master
//                              role, and the active master's answer to 0x73
//   0x72 (no data)            "flying master request": start a negotiation
//   0x73 (no data)            "active master request": who is master?
//   0x74 [priority, node-ID]  "NMT master response": a gateway able to be
//                              master is here (sent at start and right
//                              before each of its claims; the node-ID in it
//                              is our addition, so that each gateway knows
//                              the other's heartbeat is no device's and the
//                              priority it claims with)
//   0x76 [priority, node-ID]  "force flying master negotiation" (CiA 302-2
//                              has no data; the gateway asking names itself)
//   0x700 + node-ID [state]   each gateway's heartbeat (CiA 301): master
//                              operational (05h), every other pre-operational
//                              (7Fh), so a candump shows the roles
// A gateway starts by asking (0x73). The active master answers with 0x71 and
// the newcomer is standby. When nobody answers, or when a standby misses the
// master's heartbeat for 1.5 periods, it sends 0x72 and every candidate
// waits priority * 300 ms + node-ID * 2 ms before claiming with 0x71: the
// best (lowest priority value, then lowest node-ID) claims first and the
// others, seeing the claim, stand by; one that outranks a live claimant
// (its own slot ran late: a slot is 2 ms a node-ID) claims at once instead.
// A claim is held for a settle time
// before the role is taken; two claims in that time (or two masters after a
// healed bus split: the master repeats its claim every tenth heartbeat) are
// settled by the same order, so the bus never keeps two masters. The role
// becomes master only after the settle time; until then, and as standby,
// the owner sends nothing but these frames.
//
// What a stranger on the bus cannot do (any process may send any frame on a
// CAN bus, docs/security.md "Raw CAN"):
//   * Claims (0x71) and announcements (0x74) count only from a plausible
//     gateway (canopen/election_peers: node-ID 1..127, not ours, priority
//     0..2, never an excluded node-ID: the bus's configured devices, the
//     devices it knows, its written node pool). A gateway's priority is the
//     one it announced; another announced while its heartbeat is heard is
//     refused (a restart, a silence, may change it).
//   * A master or a claimant yields only to a gateway that announced itself
//     (0x74), is live (its heartbeat heard within 1.5 periods) and claims
//     with the priority it announced; a newcomer or a negotiating gateway
//     follows any plausible claim, but only for 1.5 heartbeat periods unless
//     the claimant's heartbeat says 05h (operational): a claim nobody backs
//     is forgotten and the follower negotiates again, from where it was when
//     the claim came (its wait is not restarted: forged claims in a
//     negotiation delay the master by at most 1.5 periods). A followed master is
//     alive only while its heartbeat says 05h; a 7Fh (a standby's) keeps
//     nothing alive, so two standbys never follow each other.
//   * 0x76 carries [priority, node-ID] of the gateway asking (our addition;
//     CiA 302-2's has no data) and is honoured only when that names a live
//     peer gateway of higher rank than ours: the only 0x76 this gateway sends
//     is a preempt, which only a gateway of higher rank sends. A bare 0x76 or
//     one naming anyone else is ignored and counted.
//   * Hold-down: a master hands the role over on a 0x76 at most once per
//     kHandoverHoldDown (60 s), so a 0x76 storm makes at most one handover
//     (a master leaving, another taking: 2 role changes) a minute. A lost
//     master, a better claim and the start are not held down: the bus must
//     have a master.
// Where this differs from CiA 302-2: no NMT startup object (0x1F80) or
// timing object (0x1F90) in an object dictionary (the settings come from the
// gateway's configuration); the active master does not re-announce itself on
// slaves' boot-ups; a returning gateway of higher priority takes the role
// back only when configured to (preempt, after a hold time, asking again
// every hold time while the master holds the role down) and never while
// the master reports itself busy (a device mid-configuration).
//
// Thread: one thread (the bus control thread) calls everything; no locks,
// no allocation after construction. The callback runs synchronously from
// on_frame()/process() and must not block.
#pragma once

#include <cstdint>
#include <functional>
#include <string_view>

#include "can/frame.hpp"
#include "can/frame_sink.hpp"
#include "canopen/clock.hpp"
#include "canopen/election_peers.hpp"

namespace cobridge::canopen {

namespace cob {
inline constexpr uint32_t kMasterNodeId = 0x71;         // claim / answer: [priority, node-ID]
inline constexpr uint32_t kFlyingMasterRequest = 0x72;  // start a negotiation
inline constexpr uint32_t kActiveMasterRequest = 0x73;  // who is the active master?
inline constexpr uint32_t kMasterResponse = 0x74;       // a master-capable gateway: [priority, node-ID]
inline constexpr uint32_t kForceNegotiation = 0x76;     // force a negotiation
}  // namespace cob

struct MasterElectionConfig {
  uint8_t node_id = 0;    // this gateway's node-ID on the bus, 1..127
  uint8_t priority = 0;   // 0 (high) .. 2 (low), CiA 302-2
  Duration heartbeat{std::chrono::milliseconds(100)};
  bool preempt = false;   // take the role back from a master of lower rank
  Duration hold{std::chrono::seconds(10)};  // ... after this long as standby
  Duration settle{std::chrono::milliseconds(50)};
};

enum class MasterRole : uint8_t { starting, negotiating, claiming, master, standby };
[[nodiscard]] std::string_view to_string(MasterRole role) noexcept;

enum class ElectionCause : uint8_t {
  master_answered,      // our active master request was answered
  no_master,            // nobody answered it
  master_lost,          // the master's heartbeat stopped
  negotiation_requested,  // another gateway asked for a negotiation
  won,                  // our claim held for the settle time
  claimed,              // another gateway claimed first while we waited
  better_claim,         // a claim of higher rank than ours
  preempted,            // a gateway of higher rank asked for the role back
  claim_unbacked,       // the gateway we followed sent no master heartbeat (05h)
};
[[nodiscard]] std::string_view to_string(ElectionCause cause) noexcept;

// Election frames that moved nothing, for the log and status.
struct ElectionCounters {
  uint32_t claims_ignored = 0;   // 0x71/0x74 naming no plausible gateway, or not as it announced
  uint32_t forces_ignored = 0;   // 0x76 naming no live peer gateway of higher rank
  uint32_t forces_held = 0;      // 0x76 from a live peer, within the hold-down of the last handover
};

struct ElectionEvent {
  MasterRole role = MasterRole::starting;
  MasterRole previous = MasterRole::starting;
  ElectionCause cause = ElectionCause::no_master;
  uint8_t master_node = 0;  // the master known after the event, 0 = none
  uint8_t master_priority = 0;
  TimePoint time{};
};

class MasterElection {
 public:
  using Callback = std::function<void(const ElectionEvent&)>;
  static constexpr Duration kPrioritySlot{std::chrono::milliseconds(300)};
  static constexpr Duration kNodeSlot{std::chrono::milliseconds(2)};
  static constexpr unsigned kAnnounceEvery = 10;  // master heartbeats per repeated claim
  static constexpr uint8_t kLowestPriority = ElectionPeers::kLowestPriority;
  // A master hands the role over on a 0x76 at most once in this time.
  static constexpr Duration kHandoverHoldDown{std::chrono::seconds(60)};

  explicit MasterElection(MasterElectionConfig config) noexcept : config_(config), peers_(config.node_id) {}
  void set_callback(Callback callback) { callback_ = std::move(callback); }

  // Node-IDs that are no gateway's (configured devices, devices known on the
  // bus, the written node pool): claims, announcements and heartbeats of
  // these are never the election's. May be called any time (a reload).
  void set_excluded(const NodeSet& excluded) noexcept { peers_.set_excluded(excluded); }
  [[nodiscard]] const NodeSet& excluded() const noexcept { return peers_.excluded(); }
  [[nodiscard]] const ElectionCounters& counters() const noexcept { return counters_; }

  // Asks who the master is; the answer (or its absence) decides the role.
  void start(TimePoint now, can::FrameSink& out) noexcept;
  // Every received frame; true when it was an election frame or the
  // master's heartbeat.
  bool on_frame(const can::Frame& frame, TimePoint now, can::FrameSink& out) noexcept;
  // Timers: heartbeat, answer wait, negotiation slot, settle, master loss.
  // Returns the next deadline.
  TimePoint process(TimePoint now, can::FrameSink& out) noexcept;

  // While busy (a device mid-configuration), a request to give the role back
  // waits; the role is handed over once the owner clears it.
  void set_busy(bool busy) noexcept { busy_ = busy; }

  [[nodiscard]] MasterRole role() const noexcept { return role_; }
  [[nodiscard]] bool is_master() const noexcept { return role_ == MasterRole::master; }
  [[nodiscard]] uint8_t master_node() const noexcept { return master_node_; }
  [[nodiscard]] uint8_t master_priority() const noexcept { return master_priority_; }
  [[nodiscard]] const ElectionEvent& last_event() const noexcept { return last_; }
  [[nodiscard]] const MasterElectionConfig& config() const noexcept { return config_; }
  [[nodiscard]] Duration master_timeout() const noexcept { return config_.heartbeat + config_.heartbeat / 2; }
  // A node-ID a gateway of this bus uses (ours, one that announced itself,
  // or the master we follow), never an excluded one: its heartbeat is the
  // election's, not a device's.
  [[nodiscard]] bool is_gateway(uint8_t node) const noexcept { return peers_.is_gateway(node, master_node_); }
  // The other gateway of the pair: the lowest node-ID that announced itself
  // and is not ours (else the master we follow), 0 = none heard yet.
  [[nodiscard]] uint8_t peer_node() const noexcept { return peers_.peer(master_node_); }
  // Frames that belong to the election only: 0x71..0x76, and the heartbeat
  // of a gateway.
  [[nodiscard]] bool owns(const can::Frame& frame) const noexcept;

 private:
  // Rank order: lower priority value first, then lower node-ID.
  [[nodiscard]] bool outranks_us(uint8_t priority, uint8_t node) const noexcept;
  // A yield to `node` (its claim, its 0x76) only when it is a live peer.
  [[nodiscard]] bool live_peer(uint8_t priority, uint8_t node, TimePoint now) const noexcept {
    return peers_.live(priority, node, now, master_timeout());
  }
  void change(MasterRole role, ElectionCause cause, TimePoint now) noexcept;
  void negotiate(ElectionCause cause, TimePoint now) noexcept;
  void claim(TimePoint now, can::FrameSink& out) noexcept;
  void follow(uint8_t priority, uint8_t node, ElectionCause cause, TimePoint now) noexcept;
  void on_claim_frame(const can::Frame& frame, TimePoint now, can::FrameSink& out) noexcept;
  void on_claim(uint8_t priority, uint8_t node, TimePoint now, can::FrameSink& out) noexcept;
  void on_claim_as_master(uint8_t priority, uint8_t node, TimePoint now, can::FrameSink& out) noexcept;
  void on_announce(const can::Frame& frame, TimePoint now) noexcept;
  bool on_heartbeat(const can::Frame& frame, TimePoint now) noexcept;
  void on_force(const can::Frame& frame, TimePoint now, can::FrameSink& out) noexcept;
  void hand_over(TimePoint now, can::FrameSink& out) noexcept;
  void send_claim(can::FrameSink& out) noexcept;
  void send_heartbeat(can::FrameSink& out) noexcept;
  TimePoint step_role(TimePoint now, can::FrameSink& out) noexcept;
  TimePoint step_master(TimePoint now, can::FrameSink& out) noexcept;
  TimePoint step_standby(TimePoint now, can::FrameSink& out) noexcept;

  MasterElectionConfig config_;
  Callback callback_;
  MasterRole role_ = MasterRole::starting;
  uint8_t master_node_ = 0;
  uint8_t master_priority_ = 0;
  TimePoint deadline_ = kNever;        // of the present role's wait (answer, slot, settle)
  TimePoint master_seen_ = kNever;     // standby: the master's last 05h heartbeat (or its claim)
  TimePoint next_heartbeat_ = kNever;
  bool busy_ = false;
  bool handover_pending_ = false;  // a force request waits for busy_ to clear
  TimePoint next_preempt_ = kNever;   // standby with preempt: when to ask (0x76) again
  TimePoint last_handover_ = kNever;  // the last 0x76 this master honoured
  bool backed_ = false;            // standby: the master's heartbeat said 05h since we followed it
  TimePoint resume_at_ = kNever;   // standby, not backed yet: the deadline of the negotiation we left
  unsigned beats_ = 0;
  ElectionPeers peers_;
  ElectionCounters counters_;
  ElectionEvent last_{};
};

}  // namespace cobridge::canopen
