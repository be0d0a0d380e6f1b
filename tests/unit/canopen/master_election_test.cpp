// MasterElection: one NMT master per bus among gateways, after CiA 302-2's
// NMT flying master (active master detection 0x73, negotiation 0x72,
// claims 0x71 [priority, node-ID], forced negotiation 0x76).
#include "canopen/master_election.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "canopen/cob_id.hpp"

namespace cobridge::canopen {
namespace {

using namespace std::chrono_literals;
using can::Frame;

// Gateways on one bus, stepped in 1 ms ticks: a frame one sends reaches the
// others in the same tick, as on a CAN bus (a sender does not see its own).
class Bus {
 public:
  struct Gateway : can::FrameSink {
    explicit Gateway(MasterElectionConfig c) : election(c) {}
    bool send(const Frame& f) noexcept override {
      sent.push_back({f, now});
      pending.push_back(f);
      return true;
    }
    MasterElection election;
    struct Sent {
      Frame frame;
      TimePoint at;
    };
    std::vector<Sent> sent;
    std::vector<Frame> pending;
    std::vector<ElectionEvent> events;
    TimePoint now{};
    bool alive = true;
  };

  Gateway& add(uint8_t node, uint8_t priority = 0, bool preempt = false, Duration hold = 10s) {
    MasterElectionConfig c;
    c.node_id = node;
    c.priority = priority;
    c.preempt = preempt;
    c.hold = hold;
    gws_.push_back(std::make_unique<Gateway>(c));
    Gateway* g = gws_.back().get();
    g->election.set_callback([g](const ElectionEvent& e) { g->events.push_back(e); });
    return *g;
  }
  void start(Gateway& g) {
    g.now = now_;
    g.election.start(now_, g);
    deliver();
  }
  // Runs until `d` has passed; `each` is checked after every tick.
  template <typename Check>
  void run(Duration d, Check each) {
    const TimePoint end = now_ + d;
    while (now_ < end) {
      now_ += 1ms;
      for (auto& g : gws_) {
        if (!g->alive) continue;
        g->now = now_;
        (void)g->election.process(now_, *g);
      }
      deliver();
      each();
    }
  }
  void run(Duration d) {
    run(d, [] {});
  }
  [[nodiscard]] int masters() const {
    int n = 0;
    for (const auto& g : gws_) n += g->alive && g->election.is_master() ? 1 : 0;
    return n;
  }
  [[nodiscard]] TimePoint now() const { return now_; }

 private:
  void deliver() {
    for (bool more = true; more;) {
      more = false;
      for (auto& from : gws_) {
        std::vector<Frame> frames;
        frames.swap(from->pending);
        for (const Frame& f : frames) {
          more = true;
          for (auto& to : gws_) {
            if (to.get() == from.get() || !to->alive) continue;
            to->now = now_;
            (void)to->election.on_frame(f, now_, *to);
          }
        }
      }
    }
  }
  std::vector<std::unique_ptr<Gateway>> gws_;
  TimePoint now_ = TimePoint{} + 1h;
};

bool sent_id(const Bus::Gateway& g, uint32_t id) {
  for (const auto& s : g.sent)
    if (s.frame.id == id) return true;
  return false;
}

// CiA 302-2 active master detection: nobody answers 0x73, so the gateway
// asks for a negotiation (0x72), claims (0x71 [priority, node-ID]) in its
// slot, and is master after the settle time; its heartbeat says operational.
TEST(MasterElection, CiA302_2_AloneItBecomesMasterAfterNoAnswer) {
  Bus bus;
  auto& a = bus.add(5, 1);
  bus.start(a);
  ASSERT_FALSE(a.sent.empty());
  EXPECT_EQ(a.sent[0].frame, Frame::make(cob::kActiveMasterRequest, {}));
  EXPECT_EQ(a.election.role(), MasterRole::starting);
  bus.run(1s);
  ASSERT_TRUE(a.election.is_master());
  EXPECT_TRUE(sent_id(a, cob::kFlyingMasterRequest));
  bool claimed = false;
  for (const auto& s : a.sent) claimed |= s.frame == Frame::make(cob::kMasterNodeId, {1, 5});
  EXPECT_TRUE(claimed);
  EXPECT_EQ(a.sent.back().frame.id, cob::kNmtErrorControlBase + 5);
  EXPECT_EQ(a.sent.back().frame.data[0], 0x05);
  ASSERT_FALSE(a.events.empty());
  EXPECT_EQ(a.events.back().cause, ElectionCause::won);
  EXPECT_EQ(a.election.master_node(), 5);
}

// A gateway that starts beside an active master asks, is answered by the
// master's claim and stands by: it never claims, and its heartbeat says
// pre-operational.
TEST(MasterElection, CiA302_2_ANewcomerFindsTheMasterAndStandsBy) {
  Bus bus;
  auto& a = bus.add(2);
  bus.start(a);
  bus.run(1s);
  ASSERT_TRUE(a.election.is_master());
  auto& b = bus.add(1);  // of higher rank, but the role is taken
  bus.start(b);
  bus.run(5s, [&] { ASSERT_EQ(bus.masters(), 1); });
  EXPECT_EQ(b.election.role(), MasterRole::standby);
  EXPECT_EQ(b.election.master_node(), 2);
  EXPECT_EQ(b.events.back().cause, ElectionCause::master_answered);
  EXPECT_FALSE(sent_id(b, cob::kMasterNodeId));
  EXPECT_FALSE(sent_id(b, cob::kForceNegotiation));  // no preemption unless configured
  for (const auto& s : b.sent) {
    const bool election = s.frame.id == cob::kActiveMasterRequest || s.frame.id == cob::kMasterResponse;
    const bool heartbeat = s.frame.id == cob::kNmtErrorControlBase + 1 && s.frame.data[0] == 0x7F;
    EXPECT_TRUE(election || heartbeat) << "standby sent 0x" << std::hex << s.frame.id;
  }
}

// Two gateways started together: exactly one master at every tick, the one
// of higher rank (same priority: the lower node-ID).
TEST(MasterElection, CiA302_2_TwoStartedTogetherEndWithOneMaster) {
  Bus bus;
  auto& a = bus.add(7);
  auto& b = bus.add(3);
  bus.start(a);
  bus.start(b);
  bus.run(3s, [&] { ASSERT_LE(bus.masters(), 1); });
  EXPECT_TRUE(b.election.is_master());
  EXPECT_EQ(a.election.role(), MasterRole::standby);
  EXPECT_EQ(a.election.master_node(), 3);
}

// The master dies (its frames stop): the standby is master within 1 s of the
// master's last frame, with the default 100 ms master heartbeat.
TEST(MasterElection, TakeoverWithinOneSecondOfTheMastersLastFrame) {
  Bus bus;
  auto& a = bus.add(1);
  auto& b = bus.add(2);
  bus.start(a);
  bus.run(1s);
  bus.start(b);
  bus.run(2s);
  ASSERT_TRUE(a.election.is_master());
  a.alive = false;
  const TimePoint last = a.sent.back().at;
  TimePoint became{};
  bus.run(2s, [&] {
    if (b.election.is_master() && became == TimePoint{}) became = bus.now();
  });
  ASSERT_TRUE(b.election.is_master());
  EXPECT_LE(became - last, 1s);
  EXPECT_EQ(b.events.back().cause, ElectionCause::won);
  bool lost = false;
  for (const auto& e : b.events) lost |= e.cause == ElectionCause::master_lost;
  EXPECT_TRUE(lost);
}

// Two masters (a bus split healed, or claims crossing within the settle
// time): the rank decides; the other stands by at the next claim it hears.
TEST(MasterElection, CiA302_2_TwoMastersMeetAndTheLowerRankYields) {
  Bus bus;
  auto& a = bus.add(4);
  bus.start(a);
  bus.run(1s);
  auto& b = bus.add(9);
  b.alive = true;
  // b became master where a could not hear it: simulate by forcing b's claim
  // through its own start on a bus where a is silent for a while.
  a.alive = false;
  bus.start(b);
  bus.run(1s);
  ASSERT_TRUE(b.election.is_master());
  a.alive = true;  // the halves meet; both think they are master
  ASSERT_EQ(bus.masters(), 2);
  bus.run(3s);
  EXPECT_EQ(bus.masters(), 1);
  EXPECT_TRUE(a.election.is_master());
  EXPECT_EQ(b.election.role(), MasterRole::standby);
  EXPECT_EQ(b.events.back().cause, ElectionCause::better_claim);
}

// Preemption, when configured: a gateway of higher rank that returns stands
// by for the hold time, then asks for the role (0x76); the master hands it
// over only once it is not busy configuring a device.
TEST(MasterElection, PreemptAfterTheHoldTimeAndNeverWhileBusy) {
  Bus bus;
  auto& low = bus.add(8, 2);
  bus.start(low);
  bus.run(1s);
  auto& high = bus.add(1, 0, /*preempt=*/true, /*hold=*/2s);
  bus.start(high);
  low.election.set_busy(true);
  bus.run(1500ms);
  EXPECT_EQ(high.election.role(), MasterRole::standby);  // holding
  bus.run(2s, [&] { ASSERT_LE(bus.masters(), 1); });
  EXPECT_TRUE(sent_id(high, cob::kForceNegotiation));
  EXPECT_TRUE(low.election.is_master());  // busy: the request waits
  low.election.set_busy(false);
  bus.run(2s, [&] { ASSERT_LE(bus.masters(), 1); });
  EXPECT_TRUE(high.election.is_master());
  EXPECT_EQ(low.election.role(), MasterRole::standby);
}

// Malformed election frames change nothing: a claim without its two bytes,
// an extended or remote frame on an election identifier.
TEST(MasterElection, MalformedClaimsAreIgnored) {
  Bus bus;
  auto& a = bus.add(3);
  bus.start(a);
  const TimePoint t = bus.now();
  (void)a.election.on_frame(Frame::make(cob::kMasterNodeId, {0}), t, a);
  Frame ext = Frame::make(cob::kMasterNodeId, {0, 1});
  ext.flags |= can::Frame::kFlagExtended;
  (void)a.election.on_frame(ext, t, a);
  EXPECT_EQ(a.election.role(), MasterRole::starting);
  bus.run(1s);
  EXPECT_TRUE(a.election.is_master());
}

// Each gateway learns the other's node-ID (its 0x74 at start, its claims),
// so that the peer's heartbeat is the election's and never taken for a
// device's; frames of devices stay theirs.
TEST(MasterElection, EachKnowsTheOthersNodeIdAndOwnsOnlyElectionFrames) {
  Bus bus;
  auto& a = bus.add(20);
  bus.start(a);
  bus.run(1s);
  auto& b = bus.add(21);
  bus.start(b);
  bus.run(500ms);
  EXPECT_TRUE(a.election.is_gateway(21));
  EXPECT_TRUE(b.election.is_gateway(20));
  EXPECT_FALSE(a.election.is_gateway(5));
  EXPECT_TRUE(a.election.owns(Frame::make(cob::kNmtErrorControlBase + 21, {0x7F})));
  EXPECT_FALSE(a.election.owns(Frame::make(cob::kNmtErrorControlBase + 5, {0x05})));
  EXPECT_TRUE(a.election.owns(Frame::make(cob::kActiveMasterRequest, {})));
  EXPECT_FALSE(a.election.owns(Frame::make(0x000, {0x01, 0x00})));  // NMT start: not the election's
}

// The peer each names in its status (docs/operations.md "Hot standby",
// "Status"): the other gateway's node-ID, never its own.
TEST(MasterElection, EachNamesTheOtherAsItsPeer) {
  Bus bus;
  auto& a = bus.add(20);
  bus.start(a);
  bus.run(1s);
  EXPECT_EQ(a.election.peer_node(), 0) << "alone: no peer heard";
  auto& b = bus.add(21);
  bus.start(b);
  bus.run(500ms);
  EXPECT_EQ(a.election.peer_node(), 21);
  EXPECT_EQ(b.election.peer_node(), 20);
}

}  // namespace
}  // namespace cobridge::canopen
