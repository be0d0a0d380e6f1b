#include "canopen/heartbeat_consumer.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace cobridge::canopen {
namespace {

using namespace std::chrono_literals;
using can::Frame;
using Kind = HeartbeatConsumer::EventKind;

class HeartbeatConsumerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    hb.set_callback([this](const HeartbeatConsumer::Event& e) { events.push_back(e); });
  }
  TimePoint at(int ms) const { return t0 + std::chrono::milliseconds(ms); }

  HeartbeatConsumer hb;
  std::vector<HeartbeatConsumer::Event> events;
  const TimePoint t0 = TimePoint{} + 1h;
};

// F§7.3 0x1016/1: bits 23-16 node to monitor, bits 15-0 time in ms.
TEST(ConsumerHeartbeatEntry, F7_3_1016Layout) {
  const auto e = ConsumerHeartbeatEntry::from_raw(0x002001F4);
  EXPECT_EQ(e.node, 0x20);
  EXPECT_EQ(e.time_ms, 500);
  EXPECT_EQ(e.raw(), 0x002001F4u);
}

TEST_F(HeartbeatConsumerTest, CiA301_1016_RejectsInvalidNodeIds) {
  EXPECT_FALSE(hb.configure(0, 100ms));
  EXPECT_FALSE(hb.configure(128, 100ms));
  EXPECT_TRUE(hb.configure(127, 100ms));
}

// CiA 301 0x1016: monitoring starts with the first heartbeat.
TEST_F(HeartbeatConsumerTest, CiA301_1016_NotArmedBeforeFirstHeartbeat) {
  ASSERT_TRUE(hb.configure(5, 100ms));
  EXPECT_EQ(hb.process(at(10'000)), kNever);
  EXPECT_TRUE(events.empty());
}

// CiA 301 §7.2.8.3.2.2: heartbeat event when none arrives within the consumer time.
TEST_F(HeartbeatConsumerTest, CiA301_7_2_8_3_2_2_TimeoutAtConsumerTime) {
  ASSERT_TRUE(hb.configure(5, 100ms));
  EXPECT_TRUE(hb.on_frame(Frame::make(0x705, {0x05}), at(0)));
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, Kind::state_changed);
  EXPECT_FALSE(events[0].previous_known);
  EXPECT_EQ(events[0].state, NmtState::operational);

  EXPECT_EQ(hb.process(at(50)), at(100));
  EXPECT_EQ(hb.process(at(99)), at(100));
  EXPECT_EQ(events.size(), 1u);
  EXPECT_EQ(hb.process(at(100)), kNever);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[1].kind, Kind::timeout);
  EXPECT_EQ(events[1].node, 5);
  EXPECT_EQ(events[1].time, at(100));
  EXPECT_TRUE(hb.status(5).timed_out);
  // Reported once.
  (void)hb.process(at(500));
  EXPECT_EQ(events.size(), 2u);
}

TEST_F(HeartbeatConsumerTest, CiA301_7_2_8_3_2_2_HeartbeatRestartsTheTimer) {
  ASSERT_TRUE(hb.configure(5, 100ms));
  (void)hb.on_frame(Frame::make(0x705, {0x05}), at(0));
  (void)hb.on_frame(Frame::make(0x705, {0x05}), at(90));
  EXPECT_EQ(hb.process(at(150)), at(190));
  EXPECT_EQ(events.size(), 1u);  // same state: no second state_changed
}

// CiA 301 §7.4.8.3 (0x1017): a producer whose time is written starts its
// period over; the confirmed write counts the deadline from there, but
// never revives a consumer that has timed out or was never armed.
TEST_F(HeartbeatConsumerTest, CiA301_7_4_8_3_WrittenProducerTimeRestartsThePeriod) {
  ASSERT_TRUE(hb.configure(5, 100ms));
  hb.restart_period(5, at(50));
  EXPECT_EQ(hb.process(at(1000)), kNever) << "not armed: no heartbeat yet";
  (void)hb.on_frame(Frame::make(0x705, {0x05}), at(0));
  hb.restart_period(5, at(80));
  EXPECT_EQ(hb.process(at(150)), at(180));
  EXPECT_TRUE(events.empty() || events.back().kind != Kind::timeout);
  (void)hb.process(at(180));
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.back().kind, Kind::timeout);
  hb.restart_period(5, at(200));
  EXPECT_TRUE(hb.status(5).timed_out) << "a write does not stand in for a heartbeat after a loss";
}

TEST_F(HeartbeatConsumerTest, CiA301_7_2_8_3_2_2_RecoveredAfterTimeout) {
  ASSERT_TRUE(hb.configure(5, 100ms));
  (void)hb.on_frame(Frame::make(0x705, {0x05}), at(0));
  (void)hb.process(at(200));
  events.clear();
  (void)hb.on_frame(Frame::make(0x705, {0x05}), at(300));
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, Kind::recovered);
  EXPECT_FALSE(hb.status(5).timed_out);
  EXPECT_EQ(hb.process(at(300)), at(400));
}

TEST_F(HeartbeatConsumerTest, CiA301_7_2_8_3_2_2_StateChange) {
  ASSERT_TRUE(hb.configure(5, 100ms));
  (void)hb.on_frame(Frame::make(0x705, {0x05}), at(0));
  (void)hb.on_frame(Frame::make(0x705, {0x7F}), at(10));
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[1].kind, Kind::state_changed);
  EXPECT_TRUE(events[1].previous_known);
  EXPECT_EQ(events[1].previous, NmtState::operational);
  EXPECT_EQ(events[1].state, NmtState::pre_operational);
}

// A state the master discounted (forget_state): the same state heard again
// is reported, so the master learns that it persists; later ones are not.
TEST_F(HeartbeatConsumerTest, CiA301_7_2_8_3_2_2_ForgottenStateIsReportedAgain) {
  ASSERT_TRUE(hb.configure(5, 100ms));
  (void)hb.on_frame(Frame::make(0x705, {0x7F}), at(0));
  hb.forget_state(5);
  (void)hb.on_frame(Frame::make(0x705, {0x7F}), at(100));
  (void)hb.on_frame(Frame::make(0x705, {0x7F}), at(200));
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[1].kind, Kind::state_changed);
  EXPECT_FALSE(events[1].previous_known);
  EXPECT_EQ(events[1].state, NmtState::pre_operational);
}

// CiA 301 §7.2.8.3.3: a boot-up is reported; monitoring waits for the next heartbeat.
TEST_F(HeartbeatConsumerTest, CiA301_7_2_8_3_3_BootUpDisarms) {
  ASSERT_TRUE(hb.configure(5, 100ms));
  (void)hb.on_frame(Frame::make(0x705, {0x05}), at(0));
  EXPECT_TRUE(hb.on_frame(Frame::make(0x705, {0x00}), at(50)));
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[1].kind, Kind::boot_up);
  EXPECT_EQ(events[1].previous, NmtState::operational);
  EXPECT_EQ(hb.process(at(1000)), kNever);
  EXPECT_EQ(events.size(), 2u);
  (void)hb.on_frame(Frame::make(0x705, {0x7F}), at(1000));
  EXPECT_EQ(hb.process(at(1000)), at(1100));
}

TEST_F(HeartbeatConsumerTest, CiA301_1016_UnconfiguredAndMalformedIgnored) {
  ASSERT_TRUE(hb.configure(5, 100ms));
  EXPECT_FALSE(hb.on_frame(Frame::make(0x706, {0x05}), at(0)));
  EXPECT_FALSE(hb.on_frame(Frame::make(0x705, {0x05, 0x00}), at(0)));
  EXPECT_FALSE(hb.on_frame(Frame::make(0x705, {0x42}), at(0)));
  EXPECT_FALSE(hb.on_frame(Frame::make(0x185, {0x05}), at(0)));
  EXPECT_TRUE(events.empty());
}

TEST_F(HeartbeatConsumerTest, CiA301_1016_NextDeadlineIsEarliestNode) {
  ASSERT_TRUE(hb.configure(1, 300ms));
  ASSERT_TRUE(hb.configure(127, 100ms));
  (void)hb.on_frame(Frame::make(0x701, {0x05}), at(0));
  (void)hb.on_frame(Frame::make(0x77F, {0x05}), at(50));
  EXPECT_EQ(hb.process(at(60)), at(150));
  (void)hb.process(at(150));
  ASSERT_EQ(events.back().kind, Kind::timeout);
  EXPECT_EQ(events.back().node, 127);
  EXPECT_EQ(hb.process(at(160)), at(300));
}

// CiA 301 0x1016: time 0 switches the entry off.
TEST_F(HeartbeatConsumerTest, CiA301_1016_ZeroTimeDisables) {
  ASSERT_TRUE(hb.configure(5, 100ms));
  (void)hb.on_frame(Frame::make(0x705, {0x05}), at(0));
  ASSERT_TRUE(hb.configure(5, 0ms));
  EXPECT_FALSE(hb.status(5).configured);
  EXPECT_EQ(hb.process(at(1000)), kNever);
  EXPECT_FALSE(hb.on_frame(Frame::make(0x705, {0x05}), at(1000)));
}

}  // namespace
}  // namespace cobridge::canopen
