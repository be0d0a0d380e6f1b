// LssMaster: the frames it puts on the wire (J§1.5, E§6), its results, and
// its timeout and error paths, against LssSlaves on the test bus.
#include "canopen/lss_master.hpp"

#include <gtest/gtest.h>

#include "unit/canopen/lss_test_bus.hpp"

namespace cobridge::canopen {
namespace {

using test::lss_rx;
using test::lss_tx;
using test::LssTestBus;
using test::RecordingSink;
using namespace std::chrono_literals;

constexpr LssAddress kJAddress{0x182, 0x0BE0, 0x00010003, 0x12345678};

std::vector<can::Frame> frames_of(const LssTestBus& bus) {
  std::vector<can::Frame> out;
  for (const auto& e : bus.log()) out.push_back(e.frame);
  return out;
}

// Puts the J§1.5 device into configuration state with switch selective.
void select_j_device(LssTestBus& bus) {
  ASSERT_FALSE(bus.master().switch_state_selective(kJAddress, bus.now()));
  auto r = bus.run_result();
  ASSERT_TRUE(r && !r->error);
  bus.clear_log();
}

// J§1.5 / E§6 switch mode selective: the master's four frames and the
// device's 0x44, byte for byte, and the result.
TEST(LssMasterTest, J1_5_SwitchSelectiveByteForByte) {
  LssTestBus bus;
  LssSlave& dev = bus.add_slave(kJAddress, 127, LssSlave::Features::rotary_j());
  bus.add_slave({0x182, 0x0BE0, 0x00010003, 0x12345679}, 127, LssSlave::Features::rotary_j());
  const TimePoint t0 = bus.now();
  ASSERT_FALSE(bus.master().switch_state_selective(kJAddress, t0));
  EXPECT_TRUE(bus.master().busy());
  auto r = bus.run_result();
  ASSERT_TRUE(r.has_value());
  EXPECT_FALSE(r->error) << r->error.message();
  EXPECT_EQ(r->operation, LssOperation::kSwitchSelective);
  EXPECT_EQ(r->address, kJAddress);
  EXPECT_EQ(r->frames_sent, 4u);
  EXPECT_EQ(r->elapsed, 1ms) << "ends at the answer, not at the timeout";
  const std::vector<can::Frame> expected{
      lss_tx({0x40, 0x82, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00}),
      lss_tx({0x41, 0xE0, 0x0B, 0x00, 0x00, 0x00, 0x00, 0x00}),
      lss_tx({0x42, 0x03, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00}),
      lss_tx({0x43, 0x78, 0x56, 0x34, 0x12, 0x00, 0x00, 0x00}),
      lss_rx({0x44, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}),
  };
  EXPECT_EQ(frames_of(bus), expected);
  EXPECT_EQ(dev.mode(), LssMode::kConfiguration);
  EXPECT_EQ(bus.slave(1).mode(), LssMode::kWaiting);
  EXPECT_FALSE(bus.master().take_result().has_value()) << "a result is taken once";
}

// J§1.5 switch mode global `04 01`, and `04 00` (the J/E "stopped" frame,
// J§1.5); no answer, so no result.
TEST(LssMasterTest, J1_5_SwitchGlobalFrames) {
  RecordingSink sink;
  LssMaster m(sink);
  EXPECT_FALSE(m.switch_state_global(LssMode::kConfiguration));
  EXPECT_FALSE(m.switch_state_global(LssMode::kWaiting));
  ASSERT_EQ(sink.frames.size(), 2u);
  EXPECT_EQ(sink.frames[0], lss_tx({0x04, 0x01, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(sink.frames[1], lss_tx({0x04, 0x00, 0, 0, 0, 0, 0, 0}));
  EXPECT_FALSE(m.busy());
  EXPECT_FALSE(m.take_result().has_value());
}

// J§1.5.1 / E§6.1 configure node-ID: `11 NID`, answer `11 00`.
TEST(LssMasterTest, J1_5_1_ConfigureNodeIdSuccess) {
  LssTestBus bus;
  LssSlave& dev = bus.add_slave(kJAddress, 127, LssSlave::Features::rotary_j());
  select_j_device(bus);
  ASSERT_FALSE(bus.master().configure_node_id(0x40, bus.now()));
  auto r = bus.run_result();
  ASSERT_TRUE(r.has_value());
  EXPECT_FALSE(r->error) << r->error.message();
  EXPECT_EQ(r->slave_error, 0);
  EXPECT_EQ(frames_of(bus), (std::vector<can::Frame>{lss_tx({0x11, 0x40, 0, 0, 0, 0, 0, 0}),
                                                     lss_rx({0x11, 0x00, 0, 0, 0, 0, 0, 0})}));
  EXPECT_EQ(dev.pending_node_id(), 0x40);
}

// J§1.5.1 / E§6.1 error 1 "node-ID out of range" for 0 and 128, reported as
// a slave error naming the service; FFh is accepted (CiA 305 V3).
TEST(LssMasterTest, J1_5_1_ConfigureNodeIdOutOfRangeIsSlaveError1) {
  LssTestBus bus;
  bus.add_slave(kJAddress, 127);
  select_j_device(bus);
  for (uint8_t bad : {uint8_t{0}, uint8_t{128}}) {
    ASSERT_FALSE(bus.master().configure_node_id(bad, bus.now()));
    auto r = bus.run_result();
    ASSERT_TRUE(r.has_value());
    EXPECT_EQ(r->error, make_lss_slave_error(LssCs::kConfigureNodeId, 1));
    EXPECT_EQ(r->error.category(), lss_slave_error_category());
    EXPECT_EQ(r->error.message(), "configure node-ID: node-ID out of range");
    EXPECT_EQ(r->slave_error, 1);
    EXPECT_EQ(bus.log().back().frame, lss_rx({0x11, 0x01, 0, 0, 0, 0, 0, 0}));
  }
  ASSERT_FALSE(bus.master().configure_node_id(0xFF, bus.now()));
  auto r = bus.run_result();
  ASSERT_TRUE(r.has_value());
  EXPECT_FALSE(r->error);
}

// E§6.2 / CiA 305 configure bit timing: the master sends `13 00 IDX`
// (CiA 305: the gateway sends the CiA form); index 7 (20k) -> error 1.
TEST(LssMasterTest, E6_2_ConfigureBitTimingCiaFormAndNotSupported) {
  LssTestBus bus;
  LssSlave& dev = bus.add_slave(kJAddress, 127);
  select_j_device(bus);
  ASSERT_FALSE(bus.master().configure_bit_timing(0x04, bus.now()));
  auto r = bus.run_result();
  ASSERT_TRUE(r.has_value());
  EXPECT_FALSE(r->error);
  EXPECT_EQ(bus.log().front().frame, lss_tx({0x13, 0x00, 0x04, 0, 0, 0, 0, 0}));
  EXPECT_EQ(dev.pending_bit_timing(), std::optional<uint8_t>(4));

  ASSERT_FALSE(bus.master().configure_bit_timing(0x07, bus.now()));
  r = bus.run_result();
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->error, make_lss_slave_error(LssCs::kConfigureBitTiming, 1));
  EXPECT_EQ(r->error.message(), "configure bit timing: bit timing not supported");
}

// CiA 305 activate bit timing 0x15 with the switch delay (LE u16); no answer.
TEST(LssMasterTest, CiA305_ActivateBitTimingFrame) {
  RecordingSink sink;
  LssMaster m(sink);
  EXPECT_FALSE(m.activate_bit_timing(1000));
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0], lss_tx({0x15, 0xE8, 0x03, 0, 0, 0, 0, 0}));
}

// J§1.5.3 / E§6.3 store configuration: `17 00` -> `17 00` ok, `17 02`
// storage media access error.
TEST(LssMasterTest, J1_5_3_StoreConfigurationSuccessAndMediaError) {
  LssTestBus bus;
  LssSlave& dev = bus.add_slave(kJAddress, 127);
  select_j_device(bus);
  ASSERT_FALSE(bus.master().store_configuration(bus.now()));
  auto r = bus.run_result();
  ASSERT_TRUE(r.has_value());
  EXPECT_FALSE(r->error);
  EXPECT_EQ(frames_of(bus), (std::vector<can::Frame>{lss_tx({0x17, 0, 0, 0, 0, 0, 0, 0}),
                                                     lss_rx({0x17, 0, 0, 0, 0, 0, 0, 0})}));

  dev.set_store_handler([](const LssSlave&) { return LssStoreError::kMediaAccess; });
  ASSERT_FALSE(bus.master().store_configuration(bus.now()));
  r = bus.run_result();
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->error, make_lss_slave_error(LssCs::kStoreConfiguration, 2));
  EXPECT_EQ(r->slave_error, 2);
  EXPECT_EQ(r->error.message(), "store configuration: storage media access error");
}

// CiA 305 inquire 0x5A..0x5E against the multiturn model (V3.0.0, E intro).
TEST(LssMasterTest, CiA305_InquireIdentityAndNodeId) {
  LssTestBus bus;
  bus.add_slave(kJAddress, 0x33, LssSlave::Features::multiturn_e());
  select_j_device(bus);
  const std::pair<LssCs, uint32_t> cases[] = {
      {LssCs::kInquireVendor, 0x182},           {LssCs::kInquireProduct, 0x0BE0},
      {LssCs::kInquireRevision, 0x00010003},    {LssCs::kInquireSerial, 0x12345678},
      {LssCs::kInquireNodeId, 0x33},
  };
  for (const auto& [cs, expected] : cases) {
    ASSERT_FALSE(bus.master().inquire(cs, bus.now()));
    auto r = bus.run_result();
    ASSERT_TRUE(r.has_value());
    EXPECT_FALSE(r->error);
    EXPECT_EQ(r->value, expected) << static_cast<int>(cs);
  }
  EXPECT_EQ(bus.master().inquire(LssCs::kFastscan, bus.now()), LssErrc::kInvalidArgument);
}

// CiA 305 (J§1.5 does not list inquire): a rotary device does not answer, so
// the master reports a timeout after exactly the configured timeout.
TEST(LssMasterTest, CiA305_InquireRotaryTimesOut) {
  LssTestBus bus(LssMasterConfig{25ms});
  bus.add_slave(kJAddress, 127, LssSlave::Features::rotary_j());
  select_j_device(bus);
  const TimePoint t0 = bus.now();
  ASSERT_FALSE(bus.master().inquire(LssCs::kInquireSerial, t0));
  EXPECT_EQ(bus.master().process(t0), t0 + 25ms);
  auto r = bus.run_result();
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->error, LssErrc::kTimeout);
  EXPECT_EQ(r->elapsed, 25ms);
  EXPECT_EQ(bus.now(), t0 + 25ms);
}

// CiA 305 / J§1.5: no device on the bus -> timeout error on a confirmed
// service; process() returns the deadline until then and kNever after.
TEST(LssMasterTest, CiA305_NoAnswerIsTimeout) {
  RecordingSink sink;
  LssMaster m(sink, LssMasterConfig{10ms});
  const TimePoint t0 = TimePoint{} + 5s;
  ASSERT_FALSE(m.configure_node_id(5, t0));
  EXPECT_EQ(m.process(t0 + 9ms), t0 + 10ms);
  EXPECT_FALSE(m.take_result().has_value());
  EXPECT_EQ(m.process(t0 + 10ms), kNever);
  auto r = m.take_result();
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->error, LssErrc::kTimeout);
  EXPECT_EQ(r->error.message(), "no LSS answer within the timeout");
  EXPECT_FALSE(m.busy());
}

// An answer arriving after the deadline belongs to no request: still a timeout.
TEST(LssMasterTest, CiA305_LateAnswerIsIgnored) {
  LssTestBus bus(LssMasterConfig{10ms});
  bus.add_slave(kJAddress, 127);
  select_j_device(bus);
  bus.set_slave_latency(0, 15ms);
  ASSERT_FALSE(bus.master().configure_node_id(5, bus.now()));
  auto r = bus.run_result();
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->error, LssErrc::kTimeout);
  EXPECT_EQ(bus.count(0x7E4), 1u) << "the answer did reach the bus, too late";
}

// One operation at a time; a refused frame is reported, not hidden.
TEST(LssMasterTest, BusyAndSendFailed) {
  RecordingSink sink;
  LssMaster m(sink);
  const TimePoint t0 = TimePoint{} + 1s;
  ASSERT_FALSE(m.store_configuration(t0));
  EXPECT_EQ(m.configure_node_id(1, t0), LssErrc::kBusy);
  EXPECT_EQ(m.switch_state_global(LssMode::kWaiting), LssErrc::kBusy);
  EXPECT_EQ(m.fastscan(t0), LssErrc::kBusy);
  m.cancel();
  EXPECT_FALSE(m.busy());
  EXPECT_FALSE(m.take_result().has_value());
  sink.refuse = true;
  EXPECT_EQ(m.configure_node_id(1, t0), LssErrc::kSendFailed);
  EXPECT_EQ(m.switch_state_global(LssMode::kWaiting), LssErrc::kSendFailed);
  EXPECT_FALSE(m.busy());
  EXPECT_EQ(make_error_code(LssErrc::kBusy).category().name(), std::string("lss"));
}

// CiA 305 identify remote slave: several slaves in range answer in the same
// window; the step lasts one full timeout and counts every answer.
TEST(LssMasterTest, CiA305_IdentifyRemoteSlaveCollectsAnswers) {
  LssTestBus bus(LssMasterConfig{20ms});
  for (uint32_t serial : {100u, 200u, 300u, 400u})
    bus.add_slave({0x182, 0x0BE0, 1, serial}, 127, LssSlave::Features::rotary_j());
  const TimePoint t0 = bus.now();
  ASSERT_FALSE(bus.master().identify_remote_slave({0x182, 0x0BE0, 0, 0xFFFFFFFF, 150, 350}, t0));
  auto r = bus.run_result();
  ASSERT_TRUE(r.has_value());
  EXPECT_FALSE(r->error);
  EXPECT_TRUE(r->answered);
  EXPECT_EQ(r->answers, 2u);
  EXPECT_EQ(r->frames_sent, 6u);
  EXPECT_EQ(r->elapsed, 20ms);
  EXPECT_EQ(bus.log()[0].frame, lss_tx({0x46, 0x82, 0x01, 0, 0, 0, 0, 0}));
  EXPECT_EQ(bus.log()[5].frame, lss_tx({0x4B, 0x5E, 0x01, 0, 0, 0, 0, 0}));

  ASSERT_FALSE(bus.master().identify_remote_slave({0x182, 0x0BE0, 0, 0xFFFFFFFF, 401, 0xFFFFFFFF}, bus.now()));
  r = bus.run_result();
  ASSERT_TRUE(r.has_value());
  EXPECT_FALSE(r->error) << "nobody in range is an answer, not an error";
  EXPECT_FALSE(r->answered);
}

// CiA 305 identify non-configured remote slave 0x4C -> 0x50.
TEST(LssMasterTest, CiA305_IdentifyNonConfigured) {
  LssTestBus bus(LssMasterConfig{20ms});
  bus.add_slave(kJAddress, 127);
  ASSERT_FALSE(bus.master().identify_non_configured(bus.now()));
  auto r = bus.run_result();
  ASSERT_TRUE(r.has_value());
  EXPECT_FALSE(r->answered);
  bus.add_slave({0x182, 0x0BB8, 1, 7}, 0xFF);
  ASSERT_FALSE(bus.master().identify_non_configured(bus.now()));
  r = bus.run_result();
  ASSERT_TRUE(r.has_value());
  EXPECT_TRUE(r->answered);
  EXPECT_EQ(r->answers, 1u);
}

// The answers' kernel receive stamps (SO_TIMESTAMPNS) on a clock the test sets.
int64_t g_stamp_now_ns = 0;
int64_t stamp_clock() noexcept { return g_stamp_now_ns; }

// Identify non-configured (CiA 305) with a 100 ms wait, its answer stamped
// `answered_after` after the request and handed to the master 130 ms after
// it, as a control thread held up (an fsync, a descheduled thread) would.
std::optional<LssMaster::Result> identify_answered_late(std::optional<Duration> answered_after) {
  RecordingSink sink;
  LssMasterConfig config{100ms, {}};
  config.stamp_clock_ns = &stamp_clock;
  LssMaster master(sink, config);
  const TimePoint t0{std::chrono::seconds(3600)};
  g_stamp_now_ns = 1'700'000'000'000'000'000;
  EXPECT_FALSE(master.identify_non_configured(t0));
  can::Frame answer = test::lss_rx({0x50, 0, 0, 0, 0, 0, 0, 0});
  if (answered_after)
    answer.timestamp_ns = g_stamp_now_ns + std::chrono::duration_cast<std::chrono::nanoseconds>(*answered_after).count();
  const TimePoint handed = t0 + 130ms;
  EXPECT_TRUE(master.on_frame(answer, handed));
  (void)master.process(handed);
  return master.take_result();
}

// CiA 305 gives no answer time; the master's wait is its own. An answer
// stamped 2 ms after the request came in time, however late the control
// thread got to it; one stamped after the wait, or with no stamp and handed
// over after the wait, belongs to a step already decided.
TEST(LssMasterTest, CiA305_AnAnswerIsJudgedByItsKernelStampNotByWhenItIsHandedOver) {
  auto r = identify_answered_late(2ms);
  ASSERT_TRUE(r.has_value());
  EXPECT_TRUE(r->answered) << "stamped in time, handed over late";
  EXPECT_EQ(r->answers, 1u);
  r = identify_answered_late(120ms);
  ASSERT_TRUE(r.has_value());
  EXPECT_FALSE(r->answered) << "stamped after the 100 ms wait";
  r = identify_answered_late(std::nullopt);
  ASSERT_TRUE(r.has_value());
  EXPECT_FALSE(r->answered) << "no stamp: judged by when it is handed over";
}

}  // namespace
}  // namespace cobridge::canopen
