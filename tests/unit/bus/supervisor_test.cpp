// Supervisor: heartbeat consumer, node guarding, boot-up and EMCY turned into
// DeviceStatus changes, on a fake clock (no sleeps).
#include "bus/supervisor.hpp"

#include "canopen/emcy.hpp"
#include "canopen/nmt.hpp"
#include "device/emcy_meaning.hpp"
#include "families/ifm_rm.hpp"
#include "families/novotechnik.hpp"
#include "families/novotechnik_multiturn.hpp"
#include "families/novotechnik_rotary.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace cobridge::bus {
namespace {

using namespace std::chrono_literals;
using canopen::NmtState;
using canopen::TimePoint;
namespace fam = cobridge::families;

class CaptureSink final : public can::FrameSink {
 public:
  bool send(const can::Frame& frame) noexcept override {
    frames.push_back(frame);
    return true;
  }
  std::vector<can::Frame> frames;
};

class SupervisorTest : public ::testing::Test {
 protected:
  TimePoint t0 = TimePoint{} + 1000s;
  Supervisor sup;
  CaptureSink sink;
  DeviceStatus dev;

  void SetUp() override {
    dev.name = "enc1";
    dev.node_id = 5;
    dev.state = DeviceState::operational;
    dev.online = true;
  }
  // Applies every pending change to `dev`; returns them.
  std::vector<Supervisor::Change> drain() {
    auto changes = sup.take_changes();
    for (const auto& c : changes) apply(c, dev, WallTime{} + std::chrono::duration_cast<WallTime::duration>(
                                                             c.at.time_since_epoch()));
    return changes;
  }
  static Supervision heartbeat(std::chrono::milliseconds producer) {
    Supervision s;
    s.mode = Supervision::Mode::heartbeat;
    s.producer_time = producer;
    return s;
  }
};

// Consumer time = 1.5 x producer time + margin (gateway policy on top of
// CiA 301 §7.2.8.3.2.2, which leaves the consumer time to the application).
TEST(ConsumerTime, IsOneAndAHalfProducerTimesPlusMargin) {
  EXPECT_EQ(consumer_time_for(100ms), 150ms + kConsumerMargin);
  EXPECT_EQ(consumer_time_for(1000ms), 1500ms + kConsumerMargin);
  EXPECT_EQ(consumer_time_for(0ms), 0ms);  // 0x1017 = 0: no heartbeat
}

// A gateway that loses its bus is visible within 1 s (docs/dds.md "Many
// gateways in one domain"; docs/reliability.md): when the CAN interface goes
// down, every watched device is offline at once with the reason, not one
// consumer time later (CiA 301 §7.2.8.3.2.2 would report it only then); the
// consumer's own timeout afterwards is not reported again, and the first
// heartbeat after the bus is back brings it online.
TEST_F(SupervisorTest, BusLostTakesEveryWatchedDeviceOfflineAtOnce) {
  sup.watch(5, &fam::kNovotechnikRotary, heartbeat(100ms), t0);
  sup.watch(6, &fam::kNovotechnikRotary, heartbeat(100ms), t0);
  sup.listen(7, &fam::kNovotechnikRotary);  // being configured: not supervised yet
  sup.on_frame(canopen::make_heartbeat(5, NmtState::operational), t0 + 10ms);
  sup.on_frame(canopen::make_heartbeat(6, NmtState::operational), t0 + 10ms);
  ASSERT_EQ(drain().size(), 2U);

  sup.bus_lost(t0 + 50ms, "the CAN interface went down");
  const auto lost = drain();
  ASSERT_EQ(lost.size(), 2U);
  for (const auto& c : lost) {
    EXPECT_EQ(c.kind, Supervisor::ChangeKind::offline);
    EXPECT_EQ(c.at, t0 + 50ms) << "at once, not after the consumer time";
    EXPECT_EQ(c.reason, "the CAN interface went down");
  }
  EXPECT_FALSE(sup.online(5));
  EXPECT_FALSE(sup.online(6));
  EXPECT_FALSE(dev.online);
  EXPECT_EQ(dev.state, DeviceState::offline);
  EXPECT_EQ(dev.last_error, "the CAN interface went down");

  sup.process(t0 + 10ms + consumer_time_for(100ms) + 1ms, sink);
  EXPECT_TRUE(drain().empty()) << "the heartbeat timeout later is the same loss";
  sup.bus_lost(t0 + 400ms, "the CAN interface went down");
  EXPECT_TRUE(drain().empty()) << "reported once";

  sup.on_frame(canopen::make_heartbeat(5, NmtState::operational), t0 + 500ms);
  const auto back = drain();
  ASSERT_EQ(back.size(), 1U);
  EXPECT_EQ(back[0].kind, Supervisor::ChangeKind::online);
  EXPECT_TRUE(sup.online(5));
}

// CiA 301 §7.2.8.3.2.2: heartbeat event when no heartbeat arrives within the
// consumer time; the device is offline with reason and back on the next one.
TEST_F(SupervisorTest, Cia301_7_2_8_3_2_2_HeartbeatLostThenBackOnline) {
  sup.watch(5, &fam::kNovotechnikRotary, heartbeat(100ms), t0);
  const auto consumer = consumer_time_for(100ms);  // 200 ms
  ASSERT_TRUE(sup.on_frame(canopen::make_heartbeat(5, NmtState::operational), t0 + 10ms));
  auto changes = drain();
  ASSERT_EQ(changes.size(), 1U);
  EXPECT_EQ(changes[0].kind, Supervisor::ChangeKind::online);
  EXPECT_TRUE(sup.online(5));

  // Heartbeats in time keep it online.
  for (int i = 1; i <= 5; ++i) {
    sup.on_frame(canopen::make_heartbeat(5, NmtState::operational), t0 + 10ms + i * 100ms);
    sup.process(t0 + 10ms + i * 100ms + 50ms, sink);
  }
  EXPECT_TRUE(drain().empty());
  const TimePoint last = t0 + 510ms;

  // One tick before the consumer time: still online; the deadline is reported.
  EXPECT_EQ(sup.process(last + consumer - 1ms, sink), last + consumer);
  EXPECT_TRUE(drain().empty());
  sup.process(last + consumer, sink);
  changes = drain();
  ASSERT_EQ(changes.size(), 1U);
  EXPECT_EQ(changes[0].kind, Supervisor::ChangeKind::offline);
  // The cause in words, with the measured silence and the times it was judged by.
  EXPECT_EQ(changes[0].reason, "heartbeat lost: none for 200 ms (consumer time 200 ms, producer time 100 ms)");
  EXPECT_EQ(changes[0].at, last + consumer);
  EXPECT_EQ(dev.state, DeviceState::offline);
  EXPECT_FALSE(dev.online);
  EXPECT_EQ(dev.last_error, changes[0].reason);
  EXPECT_EQ(dev.since.time_since_epoch(), std::chrono::duration_cast<WallTime::duration>(
                                              (last + consumer).time_since_epoch()));

  // Reported once, however long the silence lasts.
  sup.process(last + 5s, sink);
  EXPECT_TRUE(drain().empty());

  sup.on_frame(canopen::make_heartbeat(5, NmtState::operational), last + 6s);
  changes = drain();
  ASSERT_EQ(changes.size(), 1U);
  EXPECT_EQ(changes[0].kind, Supervisor::ChangeKind::online);
  EXPECT_EQ(changes[0].reason, "heard again after 6000 ms of silence");  // the gap, measured
  EXPECT_EQ(dev.state, DeviceState::operational);
  EXPECT_TRUE(dev.online);
  EXPECT_TRUE(dev.last_error.empty());
}

// The NMT state the last heartbeat reported (CiA 301 §7.2.8.3.2.2: the
// heartbeat carries it); a client's NMT start relies on it when the stop it
// follows never showed in a heartbeat (test_ascii_gateway).
TEST_F(SupervisorTest, Cia301_7_2_8_3_2_2_LastReportedNmtState) {
  EXPECT_EQ(sup.nmt(5), NmtState::boot_up);  // nothing heard yet
  sup.watch(5, &fam::kNovotechnikRotary, heartbeat(100ms), t0);
  sup.on_frame(canopen::make_heartbeat(5, NmtState::operational), t0 + 10ms);
  EXPECT_EQ(sup.nmt(5), NmtState::operational);
  sup.on_frame(canopen::make_heartbeat(5, NmtState::stopped), t0 + 110ms);
  EXPECT_EQ(sup.nmt(5), NmtState::stopped);
  EXPECT_EQ(sup.nmt(0), NmtState::boot_up);    // not a node-ID
  EXPECT_EQ(sup.nmt(200), NmtState::boot_up);
}

// A device reconfigured while running (new settings on reload) is watched
// anew: online is reported again with its first heartbeat under the new
// producer time (CiA 301 §7.2.8.3.2.2, monitoring restarts).
TEST_F(SupervisorTest, Cia301_7_2_8_3_2_2_RewatchReportsOnlineAgain) {
  sup.watch(5, &fam::kIfmRm, heartbeat(100ms), t0);
  sup.on_frame(canopen::make_heartbeat(5, NmtState::operational), t0);
  ASSERT_EQ(drain().size(), 1U);
  sup.watch(5, &fam::kIfmRm, heartbeat(200ms), t0 + 1s);
  EXPECT_FALSE(sup.online(5));
  sup.on_frame(canopen::make_heartbeat(5, NmtState::operational), t0 + 1s + 10ms);
  const auto changes = drain();
  ASSERT_EQ(changes.size(), 1U);
  EXPECT_EQ(changes[0].kind, Supervisor::ChangeKind::online);
  // The new consumer time applies: 200 ms x 1.5 + margin.
  EXPECT_EQ(sup.process(t0 + 1s + 20ms, sink), t0 + 1s + 10ms + consumer_time_for(200ms));
}

// CiA 301 §7.5.2.33 (0x1016): monitoring starts with the first heartbeat;
// the gateway adds its own check so a started device that never sends one is
// reported.
TEST_F(SupervisorTest, Cia301_0x1016_NoHeartbeatAfterStartIsReported) {
  sup.watch(5, &fam::kIfmRm, heartbeat(100ms), t0);
  EXPECT_EQ(sup.process(t0, sink), t0 + consumer_time_for(100ms));
  sup.process(t0 + consumer_time_for(100ms), sink);
  const auto changes = drain();
  ASSERT_EQ(changes.size(), 1U);
  EXPECT_EQ(changes[0].kind, Supervisor::ChangeKind::offline);
  EXPECT_EQ(changes[0].reason, "no heartbeat since start");
  sup.on_frame(canopen::make_heartbeat(5, NmtState::operational), t0 + 1s);
  ASSERT_EQ(drain().size(), 1U);
  EXPECT_TRUE(sup.online(5));
}

// CiA 301 §7.2.8.3.3: a boot-up means the device reset; it is reported as
// "rebooted", counted, and supervision stops until the manager has
// reconfigured it (no false "heartbeat lost" meanwhile).
TEST_F(SupervisorTest, Cia301_7_2_8_3_3_BootUpIsRebootedAndSuspendsSupervision) {
  sup.watch(5, &fam::kNovotechnikMultiturn, heartbeat(100ms), t0);
  sup.on_frame(canopen::make_heartbeat(5, NmtState::operational), t0 + 10ms);
  drain();
  ASSERT_TRUE(sup.on_frame(canopen::make_boot_up(5), t0 + 50ms));
  auto changes = drain();
  ASSERT_EQ(changes.size(), 1U);
  EXPECT_EQ(changes[0].kind, Supervisor::ChangeKind::rebooted);
  EXPECT_EQ(changes[0].reason, "rebooted");
  EXPECT_EQ(dev.boot_ups, 1U);
  EXPECT_FALSE(dev.online);
  EXPECT_EQ(dev.nmt, NmtState::boot_up);
  EXPECT_FALSE(sup.watching(5));
  EXPECT_EQ(sup.process(t0 + 10s, sink), canopen::kNever);
  EXPECT_TRUE(drain().empty());

  // Reconfigured and started again by the manager.
  sup.watch(5, &fam::kNovotechnikMultiturn, heartbeat(100ms), t0 + 10s);
  sup.on_frame(canopen::make_heartbeat(5, NmtState::operational), t0 + 10s + 20ms);
  changes = drain();
  ASSERT_EQ(changes.size(), 1U);
  EXPECT_EQ(changes[0].kind, Supervisor::ChangeKind::online);
}

// A boot-up of a device being configured (listen(), not yet watched) is
// reported as well: the manager restarts its plan.
TEST_F(SupervisorTest, Cia301_7_2_8_3_3_BootUpWhileListening) {
  sup.listen(7, &fam::kIfmRm);
  EXPECT_FALSE(sup.on_frame(canopen::make_boot_up(8), t0));  // not ours
  ASSERT_TRUE(sup.on_frame(canopen::make_boot_up(7), t0));
  const auto changes = drain();
  ASSERT_EQ(changes.size(), 1U);
  EXPECT_EQ(changes[0].node, 7);
  EXPECT_EQ(changes[0].kind, Supervisor::ChangeKind::rebooted);
}

// J§1.8.1: EMCY 0x9080 (CAM state changed) is decoded with the rotary
// family's table, counted, and the last one kept.
TEST_F(SupervisorTest, J_1_8_1_EmcyDecodedWithFamilyTable) {
  sup.watch(5, &fam::kNovotechnikRotary, heartbeat(100ms), t0);
  const canopen::Emcy emcy{fam::kNovotechnikCamEmcy, 1, fam::rotary_cam_emcy_bytes(1, 0x0003, 0x01)};
  ASSERT_TRUE(sup.on_frame(canopen::make_emcy(5, emcy), t0 + 1ms));
  auto changes = drain();
  ASSERT_EQ(changes.size(), 1U);
  EXPECT_EQ(changes[0].kind, Supervisor::ChangeKind::emcy);
  EXPECT_EQ(dev.last_emcy_code, 0x9080);
  EXPECT_EQ(dev.last_emcy_text, device::describe_emcy(&fam::kNovotechnikRotary, emcy));
  EXPECT_NE(dev.last_emcy_text.find("Novotechnik rotary CANopen manual §1.8.1"), std::string::npos) << dev.last_emcy_text;
  EXPECT_EQ(dev.emcy_count, 1U);

  // CiA 301 §7.2.7: another EMCY replaces the last one and counts.
  canopen::Emcy voltage;
  voltage.error_code = canopen::emcy_code::kSupplyVoltage;
  voltage.error_register = 0x05;
  sup.on_frame(canopen::make_emcy(5, voltage), t0 + 2ms);
  drain();
  EXPECT_EQ(dev.last_emcy_code, 0x3100);
  EXPECT_EQ(dev.emcy_count, 2U);
  EXPECT_EQ(dev.state, DeviceState::operational);  // an EMCY alone does not make it offline
}

// E§9.1: the multiturn table decodes (code, byte 2, byte 3) sub-codes.
TEST_F(SupervisorTest, E_9_1_EmcyUsesMultiturnTable) {
  sup.watch(6, &fam::kNovotechnikMultiturn, heartbeat(100ms), t0);
  canopen::Emcy e;
  e.error_code = fam::kMultiturnMeasurementEmcy;
  e.error_register = 1;
  e.manufacturer[0] = 0;
  sup.on_frame(canopen::make_emcy(6, e), t0);
  const auto changes = sup.take_changes();
  ASSERT_EQ(changes.size(), 1U);
  EXPECT_NE(changes[0].emcy_text.find("measurement error"), std::string::npos) << changes[0].emcy_text;
  EXPECT_NE(changes[0].emcy_text.find("Novotechnik multiturn MZ1/MC1/MB1 CANopen manual §9.1"), std::string::npos) << changes[0].emcy_text;
}

// EMCY of a node nobody watches is not this supervisor's business.
TEST_F(SupervisorTest, Cia301_7_2_7_EmcyOfUnknownNodeIgnored) {
  canopen::Emcy e;
  e.error_code = 0x1000;
  EXPECT_FALSE(sup.on_frame(canopen::make_emcy(9, e), t0));
  EXPECT_TRUE(sup.take_changes().empty());
}

// CiA 301 §7.2.8.3.2.1: node guarding polls every guard time; no valid reply
// within guard time x life time factor is the node guarding event.
TEST_F(SupervisorTest, Cia301_7_2_8_3_2_1_NodeGuardingLostThenRecovered) {
  Supervision s;
  s.mode = Supervision::Mode::guarding;
  s.guard_time = 100ms;
  s.life_time_factor = 3;
  sup.watch(5, &fam::kNovotechnikRotary, s, t0);
  sup.process(t0, sink);
  ASSERT_EQ(sink.frames.size(), 1U);
  std::uint8_t node = 0;
  EXPECT_TRUE(canopen::is_guard_request(sink.frames[0], node));
  EXPECT_EQ(node, 5);
  sup.on_frame(canopen::make_guard_reply(5, NmtState::operational, false), t0 + 2ms);
  ASSERT_EQ(drain().size(), 1U);  // online
  const TimePoint valid = t0 + 2ms;

  for (int i = 1; i <= 3; ++i) sup.process(t0 + i * 100ms, sink);
  EXPECT_EQ(sink.frames.size(), 4U);
  EXPECT_TRUE(drain().empty());
  sup.process(valid + 300ms, sink);
  auto changes = drain();
  ASSERT_EQ(changes.size(), 1U);
  EXPECT_EQ(changes[0].kind, Supervisor::ChangeKind::offline);
  EXPECT_EQ(changes[0].reason, "node guarding lost");
  EXPECT_EQ(dev.state, DeviceState::offline);

  sup.on_frame(canopen::make_guard_reply(5, NmtState::operational, true), valid + 400ms);
  changes = drain();
  ASSERT_EQ(changes.size(), 1U);
  EXPECT_EQ(changes[0].kind, Supervisor::ChangeKind::online);
  EXPECT_EQ(dev.state, DeviceState::operational);
}

// CiA 301 §7.2.8.3.2.2: a heartbeat with another state (e.g. the device was
// stopped) is reported as an NMT state change, not as a loss.
TEST_F(SupervisorTest, Cia301_7_2_8_3_2_2_StateChangeReported) {
  sup.watch(5, &fam::kNovotechnikRotary, heartbeat(100ms), t0);
  sup.on_frame(canopen::make_heartbeat(5, NmtState::operational), t0);
  drain();
  sup.on_frame(canopen::make_heartbeat(5, NmtState::pre_operational), t0 + 100ms);
  const auto changes = drain();
  ASSERT_EQ(changes.size(), 1U);
  EXPECT_EQ(changes[0].kind, Supervisor::ChangeKind::nmt_state);
  EXPECT_EQ(dev.nmt, NmtState::pre_operational);
  EXPECT_TRUE(dev.online);
}

// CiA 301 §7.2.8.3.2.2 / §7.3.2: a device that comes back after a loss in
// pre-operational has reset unseen (its boot-up was lost, e.g. with the
// interface); the change is reported so the manager configures it again.
TEST_F(SupervisorTest, Cia301_7_2_8_3_2_2_BackPreOperationalAfterLossIsReported) {
  sup.watch(5, &fam::kNovotechnikRotary, heartbeat(100ms), t0);
  sup.on_frame(canopen::make_heartbeat(5, NmtState::operational), t0);
  sup.process(t0 + 1s, sink);
  drain();
  ASSERT_EQ(dev.state, DeviceState::offline);
  sup.on_frame(canopen::make_heartbeat(5, NmtState::pre_operational), t0 + 2s);
  const auto changes = drain();
  ASSERT_EQ(changes.size(), 2U);
  EXPECT_EQ(changes[0].kind, Supervisor::ChangeKind::online);
  EXPECT_EQ(changes[1].kind, Supervisor::ChangeKind::nmt_state);
  EXPECT_EQ(changes[1].nmt, NmtState::pre_operational);
  EXPECT_EQ(dev.nmt, NmtState::pre_operational);
}

}  // namespace
}  // namespace cobridge::bus

namespace cobridge::bus {
namespace {

// on_config_drift = "keep": a client set the producer
// heartbeat time (CiA 301 §7.4.8.3, 0x1017) from 100 to 9029 ms; the
// consumer follows it: 2 s of silence is no loss, 9029 ms x 1.5 + margin is.
TEST_F(SupervisorTest, Cia301_0x1017_ConsumerFollowsAProducerTimeTheGatewayKeeps) {
  sup.watch(5, &fam::kNovotechnikRotary, heartbeat(100ms), t0);
  sup.on_frame(canopen::make_heartbeat(5, NmtState::operational), t0 + 10ms);
  drain();
  ASSERT_TRUE(sup.online(5));
  EXPECT_TRUE(sup.follow_producer_time(5, 9029ms));
  sup.process(t0 + 2s, sink);
  drain();
  EXPECT_TRUE(sup.online(5)) << "silence within the new consumer time is no loss";
  sup.on_frame(canopen::make_heartbeat(5, NmtState::operational), t0 + 9s);
  sup.process(t0 + 9s + consumer_time_for(9029ms) - 1ms, sink);
  drain();
  EXPECT_TRUE(sup.online(5));
  sup.process(t0 + 9s + consumer_time_for(9029ms) + 1ms, sink);
  drain();
  EXPECT_FALSE(sup.online(5)) << "silence beyond it still is";
  EXPECT_FALSE(sup.follow_producer_time(7, 500ms)) << "a node not watched by heartbeat";
}

}  // namespace
}  // namespace cobridge::bus
