#include "canopen/node_guard.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "recording_sink.hpp"

namespace cobridge::canopen {
namespace {

using namespace std::chrono_literals;
using can::Frame;
using Kind = NodeGuardMaster::EventKind;

using test::RecordingSink;

class NodeGuardMasterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    master.set_callback([this](const NodeGuardMaster::Event& e) { events.push_back(e); });
  }
  TimePoint at(int ms) const { return t0 + std::chrono::milliseconds(ms); }
  std::vector<Kind> kinds() const {
    std::vector<Kind> k;
    for (const auto& e : events) k.push_back(e.kind);
    return k;
  }

  NodeGuardMaster master;
  RecordingSink sink;
  std::vector<NodeGuardMaster::Event> events;
  const TimePoint t0 = TimePoint{} + 1h;
};

// CiA 301 §7.2.8.3.2.1: the master polls with an RTR every guard time
// (J§1.3.1 / E§4.1 0x100C guard time in ms).
TEST_F(NodeGuardMasterTest, CiA301_7_2_8_3_2_1_PollsEveryGuardTime) {
  ASSERT_TRUE(master.configure(7, 100ms, 3, at(0)));
  EXPECT_EQ(master.process(at(0), sink), at(100));
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0], make_guard_request(7));
  EXPECT_TRUE(sink.frames[0].is_rtr());
  EXPECT_EQ(master.process(at(50), sink), at(100));
  EXPECT_EQ(sink.frames.size(), 1u);
  (void)master.process(at(100), sink);
  EXPECT_EQ(sink.frames.size(), 2u);
  EXPECT_EQ(master.status(7).requests_sent, 2u);
}

// CiA 301 §7.2.8.3.2.1: first reply toggle 0, then alternating; a reply with
// the previous toggle counts as not received.
TEST_F(NodeGuardMasterTest, CiA301_7_2_8_3_2_1_ToggleAlternates) {
  ASSERT_TRUE(master.configure(7, 100ms, 3, at(0)));
  EXPECT_TRUE(master.on_frame(make_guard_reply(7, NmtState::pre_operational, false), at(10)));
  EXPECT_TRUE(master.on_frame(make_guard_reply(7, NmtState::pre_operational, false), at(110)));
  EXPECT_TRUE(master.on_frame(make_guard_reply(7, NmtState::pre_operational, true), at(210)));
  EXPECT_EQ(kinds(), (std::vector<Kind>{Kind::state_changed, Kind::toggle_error}));
  EXPECT_EQ(master.status(7).last_valid, at(210));
  EXPECT_FALSE(master.status(7).expected_toggle);
}

TEST_F(NodeGuardMasterTest, CiA301_7_2_8_3_2_1_FirstReplyWithToggle1IsAnError) {
  ASSERT_TRUE(master.configure(7, 100ms, 3, at(0)));
  (void)master.on_frame(make_guard_reply(7, NmtState::operational, true), at(10));
  EXPECT_EQ(kinds(), (std::vector<Kind>{Kind::toggle_error}));
  EXPECT_FALSE(master.status(7).state_known);
}

// CiA 301 §7.2.8.3.2.1: node guarding event after guard time x life time factor.
TEST_F(NodeGuardMasterTest, CiA301_7_2_8_3_2_1_LostAfterLifeTime) {
  ASSERT_TRUE(master.configure(7, 100ms, 3, at(0)));
  (void)master.process(at(0), sink);
  (void)master.on_frame(make_guard_reply(7, NmtState::operational, false), at(5));
  events.clear();
  for (int t = 100; t < 305; t += 100) (void)master.process(at(t), sink);
  EXPECT_TRUE(events.empty());
  EXPECT_EQ(master.process(at(304), sink), at(305));
  (void)master.process(at(305), sink);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, Kind::lost);
  EXPECT_EQ(events[0].time, at(305));
  EXPECT_EQ(events[0].node, 7);
  // Polling goes on, and the next valid reply recovers the node.
  (void)master.process(at(400), sink);
  EXPECT_EQ(sink.frames.back(), make_guard_request(7));
  (void)master.on_frame(make_guard_reply(7, NmtState::operational, true), at(405));
  EXPECT_EQ(events.back().kind, Kind::recovered);
  EXPECT_FALSE(master.status(7).lost);
}

// CiA 301 §7.2.8.3.2.1: a reply with a wrong toggle is handled as not received.
TEST_F(NodeGuardMasterTest, CiA301_7_2_8_3_2_1_ToggleErrorsDoNotKeepNodeAlive) {
  ASSERT_TRUE(master.configure(7, 100ms, 2, at(0)));
  (void)master.on_frame(make_guard_reply(7, NmtState::operational, false), at(0));
  (void)master.on_frame(make_guard_reply(7, NmtState::operational, false), at(100));
  (void)master.on_frame(make_guard_reply(7, NmtState::operational, false), at(150));
  (void)master.process(at(200), sink);
  EXPECT_EQ(kinds(), (std::vector<Kind>{Kind::state_changed, Kind::toggle_error,
                                        Kind::toggle_error, Kind::lost}));
}

// CiA 301 §7.2.8.3.2.1: the toggle is reset to 0 only by reset communication,
// which the node announces with its boot-up.
TEST_F(NodeGuardMasterTest, CiA301_7_2_8_3_2_1_BootUpResetsToggle) {
  ASSERT_TRUE(master.configure(7, 100ms, 3, at(0)));
  (void)master.on_frame(make_guard_reply(7, NmtState::operational, false), at(0));
  EXPECT_TRUE(master.status(7).expected_toggle);
  (void)master.on_frame(make_boot_up(7), at(50));
  EXPECT_FALSE(master.status(7).expected_toggle);
  (void)master.on_frame(make_guard_reply(7, NmtState::pre_operational, false), at(100));
  EXPECT_EQ(kinds(), (std::vector<Kind>{Kind::state_changed, Kind::boot_up, Kind::state_changed}));
  EXPECT_EQ(events.back().previous, NmtState::boot_up);
  EXPECT_EQ(events.back().state, NmtState::pre_operational);
}

TEST_F(NodeGuardMasterTest, CiA301_7_2_8_3_2_1_StateChangeReported) {
  ASSERT_TRUE(master.configure(7, 100ms, 3, at(0)));
  (void)master.on_frame(make_guard_reply(7, NmtState::operational, false), at(0));
  (void)master.on_frame(make_guard_reply(7, NmtState::operational, true), at(100));
  (void)master.on_frame(make_guard_reply(7, NmtState::stopped, false), at(200));
  EXPECT_EQ(kinds(), (std::vector<Kind>{Kind::state_changed, Kind::state_changed}));
  EXPECT_EQ(events.back().previous, NmtState::operational);
  EXPECT_EQ(events.back().state, NmtState::stopped);
}

// A state the master discounted (forget_state) is reported once more when
// the next reply repeats it.
TEST_F(NodeGuardMasterTest, CiA301_7_2_8_3_2_1_ForgottenStateIsReportedAgain) {
  ASSERT_TRUE(master.configure(7, 100ms, 3, at(0)));
  (void)master.on_frame(make_guard_reply(7, NmtState::pre_operational, false), at(0));
  master.forget_state(7);
  (void)master.on_frame(make_guard_reply(7, NmtState::pre_operational, true), at(100));
  (void)master.on_frame(make_guard_reply(7, NmtState::pre_operational, false), at(200));
  EXPECT_EQ(kinds(), (std::vector<Kind>{Kind::state_changed, Kind::state_changed}));
  EXPECT_FALSE(events.back().previous_known);
}

// J§1.3.1 0x100C / 0x100D: 0 disables guarding.
TEST_F(NodeGuardMasterTest, J1_3_1_ZeroGuardTimeOrFactorDisables) {
  ASSERT_TRUE(master.configure(7, 0ms, 3, at(0)));
  ASSERT_TRUE(master.configure(8, 100ms, 0, at(0)));
  EXPECT_EQ(master.process(at(0), sink), kNever);
  EXPECT_TRUE(sink.frames.empty());
  EXPECT_FALSE(master.on_frame(make_guard_reply(7, NmtState::operational, false), at(0)));
  EXPECT_FALSE(master.configure(0, 100ms, 3, at(0)));
}

TEST_F(NodeGuardMasterTest, CiA301_7_2_8_3_2_1_SendFailureCountedNotRetriedInALoop) {
  ASSERT_TRUE(master.configure(7, 100ms, 3, at(0)));
  sink.accept = false;
  EXPECT_EQ(master.process(at(0), sink), at(100));
  EXPECT_EQ(master.status(7).send_failures, 1u);
  EXPECT_EQ(master.status(7).requests_sent, 0u);
}

TEST_F(NodeGuardMasterTest, CiA301_7_2_8_3_2_1_LateCallerDoesNotBurst) {
  ASSERT_TRUE(master.configure(7, 100ms, 50, at(0)));
  (void)master.process(at(0), sink);
  EXPECT_EQ(master.process(at(1050), sink), at(1150));
  EXPECT_EQ(sink.frames.size(), 2u);
}

// ---------------------------------------------------------------------------
// Slave side

class GuardResponderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    responder.set_callback(
        [this](GuardResponder::EventKind k, TimePoint t) { events.emplace_back(k, t); });
  }
  TimePoint at(int ms) const { return t0 + std::chrono::milliseconds(ms); }
  GuardResponder responder;
  std::vector<std::pair<GuardResponder::EventKind, TimePoint>> events;
  const TimePoint t0 = TimePoint{} + 1h;
};

// CiA 301 §7.2.8.3.2.1: replies carry the state and a toggle starting at 0.
TEST_F(GuardResponderTest, CiA301_7_2_8_3_2_1_RepliesToggle) {
  Frame out;
  ASSERT_TRUE(responder.on_frame(make_guard_request(0x7F), 0x7F, NmtState::pre_operational, at(0), out));
  EXPECT_EQ(out, Frame::make(0x77F, {0x7F}));
  ASSERT_TRUE(responder.on_frame(make_guard_request(0x7F), 0x7F, NmtState::operational, at(1), out));
  EXPECT_EQ(out, Frame::make(0x77F, {0x85}));
  ASSERT_TRUE(responder.on_frame(make_guard_request(0x7F), 0x7F, NmtState::operational, at(2), out));
  EXPECT_EQ(out, Frame::make(0x77F, {0x05}));
  // Requests for another node and data frames are not answered.
  EXPECT_FALSE(responder.on_frame(make_guard_request(0x7E), 0x7F, NmtState::operational, at(3), out));
  EXPECT_FALSE(responder.on_frame(Frame::make(0x77F, {0x05}), 0x7F, NmtState::operational, at(3), out));
}

// CiA 301 §7.2.8.3.2.1: only reset communication resets the toggle.
TEST_F(GuardResponderTest, CiA301_7_2_8_3_2_1_ResetCommunicationResetsToggle) {
  (void)responder.reply(1, NmtState::operational, at(0));
  EXPECT_TRUE(responder.next_toggle());
  responder.reset_communication();
  EXPECT_FALSE(responder.next_toggle());
  EXPECT_EQ(responder.reply(1, NmtState::pre_operational, at(1)), Frame::make(0x701, {0x7F}));
}

// CiA 301 §7.2.8.3.2.1 life guarding: starts with the first request, event
// after guard time x life time factor without a request (E§9.1 0x5000/0/0).
TEST_F(GuardResponderTest, CiA301_7_2_8_3_2_1_LifeGuarding) {
  responder.configure(100ms, 3);
  EXPECT_EQ(responder.process(at(10'000)), kNever);  // not started yet
  (void)responder.reply(1, NmtState::operational, at(0));
  EXPECT_EQ(responder.process(at(100)), at(300));
  EXPECT_TRUE(events.empty());
  EXPECT_EQ(responder.process(at(300)), kNever);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].first, GuardResponder::EventKind::life_guarding_lost);
  EXPECT_EQ(events[0].second, at(300));
  EXPECT_TRUE(responder.lost());
  (void)responder.reply(1, NmtState::operational, at(400));
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[1].first, GuardResponder::EventKind::life_guarding_resumed);
  EXPECT_EQ(responder.process(at(400)), at(700));
}

TEST_F(GuardResponderTest, J1_3_1_LifeTimeFactorZeroDisablesLifeGuarding) {
  responder.configure(100ms, 0);
  (void)responder.reply(1, NmtState::operational, at(0));
  EXPECT_EQ(responder.process(at(10'000)), kNever);
  EXPECT_TRUE(events.empty());
}

// CiA 301 §7.2.8.3.2.1 end to end: a master and a responder on a fake bus see
// no event over many cycles.
TEST(NodeGuard, CiA301_7_2_8_3_2_1_MasterAndResponderAgree) {
  NodeGuardMaster master;
  GuardResponder responder;
  responder.configure(100ms, 3);
  int master_events = 0;
  master.set_callback([&](const NodeGuardMaster::Event& e) {
    if (e.kind != NodeGuardMaster::EventKind::state_changed) ++master_events;
  });
  int responder_events = 0;
  responder.set_callback([&](GuardResponder::EventKind, TimePoint) { ++responder_events; });
  RecordingSink sink;
  const TimePoint t0 = TimePoint{} + 1h;
  ASSERT_TRUE(master.configure(9, 100ms, 3, t0));
  for (int i = 0; i < 20; ++i) {
    const TimePoint now = t0 + std::chrono::milliseconds(100 * i);
    sink.frames.clear();
    (void)master.process(now, sink);
    (void)responder.process(now);
    for (const Frame& rtr : sink.frames) {
      Frame reply;
      if (responder.on_frame(rtr, 9, NmtState::operational, now, reply))
        (void)master.on_frame(reply, now + 1ms);
    }
  }
  EXPECT_EQ(master_events, 0);
  EXPECT_EQ(responder_events, 0);
  EXPECT_EQ(master.status(9).state, NmtState::operational);
}

}  // namespace
}  // namespace cobridge::canopen
