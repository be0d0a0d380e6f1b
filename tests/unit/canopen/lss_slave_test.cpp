// LssSlave against the frames printed in J§1.5 and E§6, and the CiA 305
// services the manuals do not print (CiA 305).
#include "canopen/lss_slave.hpp"

#include <gtest/gtest.h>

#include "unit/canopen/lss_test_bus.hpp"

namespace cobridge::canopen {
namespace {

using test::lss_rx;
using test::lss_tx;
using test::RecordingSink;

// J§1.5 example identity: RFC-4800, revision 0x00010003, serial 0x12345678.
constexpr LssAddress kJAddress{0x182, 0x0BE0, 0x00010003, 0x12345678};

class LssSlaveTest : public ::testing::Test {
 protected:
  LssSlave make(const LssAddress& a = kJAddress, uint8_t node = 127,
                LssSlave::Features f = LssSlave::Features::multiturn_e()) {
    return LssSlave(sink, a, node, f);
  }
  void to_configuration(LssSlave& s) {
    ASSERT_TRUE(s.on_frame(lss_tx({0x04, 0x01, 0, 0, 0, 0, 0, 0})));
    ASSERT_EQ(s.mode(), LssMode::kConfiguration);
  }
  RecordingSink sink;
};

// J§1.5 (and E§6, same frames): switch mode selective, byte for byte.
TEST_F(LssSlaveTest, J1_5_SwitchSelectiveSequenceByteForByte) {
  LssSlave s = make(kJAddress, 127, LssSlave::Features::rotary_j());
  EXPECT_TRUE(s.on_frame(lss_tx({0x40, 0x82, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00})));
  EXPECT_TRUE(s.on_frame(lss_tx({0x41, 0xE0, 0x0B, 0x00, 0x00, 0x00, 0x00, 0x00})));
  EXPECT_TRUE(s.on_frame(lss_tx({0x42, 0x03, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00})));
  EXPECT_TRUE(sink.frames.empty()) << "no answer before the serial number";
  EXPECT_EQ(s.mode(), LssMode::kWaiting);
  EXPECT_TRUE(s.on_frame(lss_tx({0x43, 0x78, 0x56, 0x34, 0x12, 0x00, 0x00, 0x00})));
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0], lss_rx({0x44, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(s.mode(), LssMode::kConfiguration);
}

// J§1.5: only the addressed device switches; a different serial stays silent.
TEST_F(LssSlaveTest, J1_5_SwitchSelectiveOtherSerialStaysWaiting) {
  LssSlave s = make({0x182, 0x0BE0, 0x00010003, 0x12345679});
  s.on_frame(lss_tx({0x40, 0x82, 0x01, 0, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x41, 0xE0, 0x0B, 0, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x42, 0x03, 0x00, 0x01, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x43, 0x78, 0x56, 0x34, 0x12, 0, 0, 0}));
  EXPECT_TRUE(sink.frames.empty());
  EXPECT_EQ(s.mode(), LssMode::kWaiting);
}

// J§1.5 / CiA 305: the four frames must come in order; a skipped product
// frame abandons the sequence.
TEST_F(LssSlaveTest, J1_5_SwitchSelectiveOutOfOrderIsAbandoned) {
  LssSlave s = make();
  s.on_frame(lss_tx({0x40, 0x82, 0x01, 0, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x42, 0x03, 0x00, 0x01, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x43, 0x78, 0x56, 0x34, 0x12, 0, 0, 0}));
  EXPECT_TRUE(sink.frames.empty());
  EXPECT_EQ(s.mode(), LssMode::kWaiting);
}

// E§6 text gives product 0x0BB8 (the V03 multiturn code) while its frame
// table repeats J's `41 E0 0B` (E§6): a 0x0BB8 device answers the
// former and not the latter.
TEST_F(LssSlaveTest, E6_SwitchSelectiveMultiturnProduct0BB8) {
  LssSlave s = make({0x182, 0x0BB8, 0x00010003, 0x12345678});
  s.on_frame(lss_tx({0x40, 0x82, 0x01, 0, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x41, 0xE0, 0x0B, 0, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x42, 0x03, 0x00, 0x01, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x43, 0x78, 0x56, 0x34, 0x12, 0, 0, 0}));
  EXPECT_TRUE(sink.frames.empty());
  s.on_frame(lss_tx({0x40, 0x82, 0x01, 0, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x41, 0xB8, 0x0B, 0, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x42, 0x03, 0x00, 0x01, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x43, 0x78, 0x56, 0x34, 0x12, 0, 0, 0}));
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0], lss_rx({0x44, 0, 0, 0, 0, 0, 0, 0}));
}

// J§1.5 switch mode global `04 01`; J errata (J§1.5): the
// "stopped" frame `04 00` is switch state global to waiting. No answer.
TEST_F(LssSlaveTest, J1_5_SwitchGlobalFrames) {
  LssSlave s = make();
  EXPECT_TRUE(s.on_frame(lss_tx({0x04, 0x01, 0, 0, 0, 0, 0, 0})));
  EXPECT_EQ(s.mode(), LssMode::kConfiguration);
  EXPECT_TRUE(s.on_frame(lss_tx({0x04, 0x00, 0, 0, 0, 0, 0, 0})));
  EXPECT_EQ(s.mode(), LssMode::kWaiting);
  EXPECT_TRUE(sink.frames.empty());
}

// J§1.5.1 / E§6.1: configure node-ID, error 0; the new ID is pending until
// reset communication (CiA 305).
TEST_F(LssSlaveTest, J1_5_1_ConfigureNodeIdSuccess) {
  LssSlave s = make();
  to_configuration(s);
  EXPECT_TRUE(s.on_frame(lss_tx({0x11, 0x40, 0, 0, 0, 0, 0, 0})));
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0], lss_rx({0x11, 0x00, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(s.pending_node_id(), 0x40);
  EXPECT_EQ(s.active_node_id(), 127);
  s.activate_pending();
  EXPECT_EQ(s.active_node_id(), 0x40);
  EXPECT_EQ(s.mode(), LssMode::kWaiting);
}

// J§1.5.1 / E§6.1: error 1 = node-ID out of range (0, 128, FEh); the pending
// node-ID is unchanged.
TEST_F(LssSlaveTest, J1_5_1_ConfigureNodeIdOutOfRange) {
  LssSlave s = make();
  to_configuration(s);
  for (uint8_t bad : {uint8_t{0}, uint8_t{128}, uint8_t{0xFE}}) {
    sink.frames.clear();
    EXPECT_TRUE(s.on_frame(lss_tx({0x11, bad, 0, 0, 0, 0, 0, 0})));
    ASSERT_EQ(sink.frames.size(), 1u) << int{bad};
    EXPECT_EQ(sink.frames[0], lss_rx({0x11, 0x01, 0, 0, 0, 0, 0, 0})) << int{bad};
    EXPECT_EQ(s.pending_node_id(), 127);
  }
}

// CiA 305 V3: node-ID FFh is accepted and makes the device unconfigured.
// A foreign slave that refuses every node-ID (error 1) or ignores the
// request (no answer): what cobridge-sim's `assign=refuse|ignore` models
// (devices nobody configured). CiA 305 configure node-ID 0x11.
TEST_F(LssSlaveTest, CiA305_ConfigureNodeIdRefusedOrIgnored) {
  auto f = LssSlave::Features::multiturn_e();
  f.node_id_assignment = LssSlaveFeatures::NodeIdAssignment::refuse;
  LssSlave refusing = make(kJAddress, 0xFF, f);
  to_configuration(refusing);
  sink.frames.clear();
  ASSERT_TRUE(refusing.on_frame(lss_tx({0x11, 0x05, 0, 0, 0, 0, 0, 0})));
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0], lss_rx({0x11, 0x01, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(refusing.pending_node_id(), 0xFF);

  f.node_id_assignment = LssSlaveFeatures::NodeIdAssignment::ignore;
  LssSlave silent = make(kJAddress, 0xFF, f);
  to_configuration(silent);
  sink.frames.clear();
  EXPECT_TRUE(silent.on_frame(lss_tx({0x11, 0x05, 0, 0, 0, 0, 0, 0})));
  EXPECT_TRUE(sink.frames.empty());
  EXPECT_EQ(silent.pending_node_id(), 0xFF);
}

// A lossy slave (cobridge-sim `lose_configure=N`): the first N configure
// node-ID requests go unanswered, the next is answered. CiA 305 0x11.
TEST_F(LssSlaveTest, CiA305_ConfigureNodeIdLostOnceThenAnswered) {
  auto f = LssSlave::Features::multiturn_e();
  f.lose_node_id_requests = 1;
  LssSlave s = make(kJAddress, 0xFF, f);
  to_configuration(s);
  sink.frames.clear();
  EXPECT_TRUE(s.on_frame(lss_tx({0x11, 0x05, 0, 0, 0, 0, 0, 0})));
  EXPECT_TRUE(sink.frames.empty());
  EXPECT_EQ(s.pending_node_id(), 0xFF);
  EXPECT_TRUE(s.on_frame(lss_tx({0x11, 0x05, 0, 0, 0, 0, 0, 0})));
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0], lss_rx({0x11, 0x00, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(s.pending_node_id(), 5);
}

TEST_F(LssSlaveTest, CiA305_ConfigureNodeIdFFhAllowed) {
  LssSlave s = make();
  to_configuration(s);
  s.on_frame(lss_tx({0x11, 0xFF, 0, 0, 0, 0, 0, 0}));
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0], lss_rx({0x11, 0x00, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(s.pending_node_id(), 0xFF);
  EXPECT_FALSE(s.unconfigured()) << "still active at 127 until reset communication";
  s.activate_pending();
  EXPECT_TRUE(s.unconfigured());
}

// J§1.5: configuration services need configuration state; in waiting state
// the device does not answer.
TEST_F(LssSlaveTest, J1_5_ConfigureNodeIdIgnoredInWaitingState) {
  LssSlave s = make();
  EXPECT_FALSE(s.on_frame(lss_tx({0x11, 0x40, 0, 0, 0, 0, 0, 0})));
  EXPECT_TRUE(sink.frames.empty());
  EXPECT_EQ(s.pending_node_id(), 127);
}

// E§6.2 (V02 correction) / CiA 305: `13 00 IDX`, selector in byte 1.
TEST_F(LssSlaveTest, E6_2_ConfigureBitTimingCiaForm) {
  LssSlave s = make();
  to_configuration(s);
  s.on_frame(lss_tx({0x13, 0x00, 0x04, 0, 0, 0, 0, 0}));
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0], lss_rx({0x13, 0x00, 0, 0, 0, 0, 0, 0}));
  ASSERT_TRUE(s.pending_bit_timing().has_value());
  EXPECT_EQ(*s.pending_bit_timing(), 4);
  EXPECT_EQ(lss_bit_rate_kbit(*s.pending_bit_timing()), 125);
}

// J§1.5.2 prints `13 IDX 00`. The rotary model accepts
// it; a strict CiA slave reads table selector 4 and answers "not supported".
TEST_F(LssSlaveTest, J1_5_2_ConfigureBitTimingJPrintedForm) {
  LssSlave rotary = make(kJAddress, 127, LssSlave::Features::rotary_j());
  to_configuration(rotary);
  rotary.on_frame(lss_tx({0x13, 0x04, 0x00, 0, 0, 0, 0, 0}));
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0], lss_rx({0x13, 0x00, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(rotary.pending_bit_timing(), std::optional<uint8_t>(4));

  sink.frames.clear();
  LssSlave strict = make(kJAddress, 127, LssSlave::Features::multiturn_e());
  to_configuration(strict);
  strict.on_frame(lss_tx({0x13, 0x04, 0x00, 0, 0, 0, 0, 0}));
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0], lss_rx({0x13, 0x01, 0, 0, 0, 0, 0, 0}));
  EXPECT_FALSE(strict.pending_bit_timing().has_value());
}

// J§1.5.2 / E§6.2: error 1 = bit timing not supported (20k, 10k, reserved 5,
// auto 9 are outside the Novotechnik table).
TEST_F(LssSlaveTest, J1_5_2_BitTimingIndexNotSupported) {
  LssSlave s = make();
  to_configuration(s);
  for (uint8_t idx : {uint8_t{5}, uint8_t{7}, uint8_t{8}, uint8_t{9}, uint8_t{200}}) {
    sink.frames.clear();
    s.on_frame(lss_tx({0x13, 0x00, idx, 0, 0, 0, 0, 0}));
    ASSERT_EQ(sink.frames.size(), 1u);
    EXPECT_EQ(sink.frames[0], lss_rx({0x13, 0x01, 0, 0, 0, 0, 0, 0})) << int{idx};
  }
  EXPECT_FALSE(s.pending_bit_timing().has_value());
}

// CiA 305 activate bit timing 0x15: no answer; the pending index becomes
// active and the owner learns the switch delay.
TEST_F(LssSlaveTest, CiA305_ActivateBitTiming) {
  LssSlave s = make();
  to_configuration(s);
  s.on_frame(lss_tx({0x13, 0x00, 0x02, 0, 0, 0, 0, 0}));
  sink.frames.clear();
  EXPECT_TRUE(s.on_frame(lss_tx({0x15, 0xE8, 0x03, 0, 0, 0, 0, 0})));
  EXPECT_TRUE(sink.frames.empty());
  EXPECT_EQ(s.active_bit_timing(), std::optional<uint8_t>(2));
  EXPECT_EQ(s.take_bit_timing_activation(), std::optional<uint16_t>(1000));
  EXPECT_FALSE(s.take_bit_timing_activation().has_value());
}

// J§1.5.3 / E§6.3: store configuration, error 0; node-ID and bit rate stored.
TEST_F(LssSlaveTest, J1_5_3_StoreConfigurationSuccess) {
  LssSlave s = make();
  to_configuration(s);
  s.on_frame(lss_tx({0x11, 0x05, 0, 0, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x13, 0x00, 0x03, 0, 0, 0, 0, 0}));
  sink.frames.clear();
  s.on_frame(lss_tx({0x17, 0, 0, 0, 0, 0, 0, 0}));
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0], lss_rx({0x17, 0x00, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(s.stored_node_id(), std::optional<uint8_t>(5));
  EXPECT_EQ(s.stored_bit_timing(), std::optional<uint8_t>(3));
}

// J§1.5.3 / E§6.3: error 2 = storage media access error, from the store hook.
TEST_F(LssSlaveTest, J1_5_3_StoreConfigurationMediaAccessError) {
  LssSlave s = make();
  int calls = 0;
  s.set_store_handler([&calls](const LssSlave& self) {
    ++calls;
    EXPECT_EQ(self.pending_node_id(), 9);
    return LssStoreError::kMediaAccess;
  });
  to_configuration(s);
  s.on_frame(lss_tx({0x11, 0x09, 0, 0, 0, 0, 0, 0}));
  sink.frames.clear();
  s.on_frame(lss_tx({0x17, 0, 0, 0, 0, 0, 0, 0}));
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0], lss_rx({0x17, 0x02, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(calls, 1);
  EXPECT_FALSE(s.stored_node_id().has_value());
}

// CiA 305: store error 1 = not supported (a slave without non-volatile LSS store).
TEST_F(LssSlaveTest, CiA305_StoreConfigurationNotSupported) {
  LssSlave::Features f;
  f.store = false;
  LssSlave s = make(kJAddress, 127, f);
  to_configuration(s);
  s.on_frame(lss_tx({0x17, 0, 0, 0, 0, 0, 0, 0}));
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0], lss_rx({0x17, 0x01, 0, 0, 0, 0, 0, 0}));
}

// J§1.5 / E§6: "LSS can only be used when the encoder is in the stopped or
// pre-operational state"; while NMT-operational the owner sets ignore.
TEST_F(LssSlaveTest, J1_5_LssIgnoredWhileOperational) {
  LssSlave s = make();
  s.set_ignore(true);
  EXPECT_FALSE(s.on_frame(lss_tx({0x04, 0x01, 0, 0, 0, 0, 0, 0})));
  EXPECT_EQ(s.mode(), LssMode::kWaiting);
  s.set_ignore(false);
  EXPECT_TRUE(s.on_frame(lss_tx({0x04, 0x01, 0, 0, 0, 0, 0, 0})));
  EXPECT_EQ(s.mode(), LssMode::kConfiguration);
}

// CiA 305: only 8-byte data frames on 0x7E5 are LSS requests.
TEST_F(LssSlaveTest, CiA305_NonLssFramesIgnored) {
  LssSlave s = make();
  EXPECT_FALSE(s.on_frame(can::Frame::make(0x7E5, {0x04, 0x01})));
  EXPECT_FALSE(s.on_frame(can::Frame::make8(0x7E4, {0x04, 0x01, 0, 0, 0, 0, 0, 0})));
  EXPECT_EQ(s.mode(), LssMode::kWaiting);
}

// CiA 305 inquire 0x5A..0x5E (V3 multiturn, CiA 305); the J rotary model
// (DSP-305 V1.1.2, nothing in J§1.5) stays silent.
TEST_F(LssSlaveTest, CiA305_InquireIdentityAndNodeId) {
  LssSlave s = make(kJAddress, 127);
  to_configuration(s);
  s.on_frame(lss_tx({0x5A, 0, 0, 0, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x5B, 0, 0, 0, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x5C, 0, 0, 0, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x5D, 0, 0, 0, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x5E, 0, 0, 0, 0, 0, 0, 0}));
  ASSERT_EQ(sink.frames.size(), 5u);
  EXPECT_EQ(sink.frames[0], lss_rx({0x5A, 0x82, 0x01, 0, 0, 0, 0, 0}));
  EXPECT_EQ(sink.frames[1], lss_rx({0x5B, 0xE0, 0x0B, 0, 0, 0, 0, 0}));
  EXPECT_EQ(sink.frames[2], lss_rx({0x5C, 0x03, 0x00, 0x01, 0x00, 0, 0, 0}));
  EXPECT_EQ(sink.frames[3], lss_rx({0x5D, 0x78, 0x56, 0x34, 0x12, 0, 0, 0}));
  EXPECT_EQ(sink.frames[4], lss_rx({0x5E, 0x7F, 0, 0, 0, 0, 0, 0}));

  sink.frames.clear();
  LssSlave rotary = make(kJAddress, 127, LssSlave::Features::rotary_j());
  to_configuration(rotary);
  EXPECT_FALSE(rotary.on_frame(lss_tx({0x5A, 0, 0, 0, 0, 0, 0, 0})));
  EXPECT_TRUE(sink.frames.empty());
}

// CiA 305 identify remote slave 0x46..0x4B: answer 0x4F only when vendor and
// product match and revision and serial lie in the (inclusive) ranges.
TEST_F(LssSlaveTest, CiA305_IdentifyRemoteSlaveRanges) {
  LssSlave s = make(kJAddress, 127, LssSlave::Features::rotary_j());
  auto identify = [&](const LssRange& r) {
    sink.frames.clear();
    s.on_frame(lss_frame(0x7E5, 0x46, r.vendor));
    s.on_frame(lss_frame(0x7E5, 0x47, r.product));
    s.on_frame(lss_frame(0x7E5, 0x48, r.rev_lo));
    s.on_frame(lss_frame(0x7E5, 0x49, r.rev_hi));
    s.on_frame(lss_frame(0x7E5, 0x4A, r.serial_lo));
    s.on_frame(lss_frame(0x7E5, 0x4B, r.serial_hi));
    return sink.frames.size() == 1 && sink.frames[0] == lss_rx({0x4F, 0, 0, 0, 0, 0, 0, 0});
  };
  EXPECT_TRUE(identify({0x182, 0x0BE0, 0, 0xFFFFFFFF, 0, 0xFFFFFFFF}));
  EXPECT_TRUE(identify({0x182, 0x0BE0, 0x00010003, 0x00010003, 0x12345678, 0x12345678}));
  EXPECT_FALSE(identify({0x182, 0x0BE0, 0, 0xFFFFFFFF, 0x12345679, 0xFFFFFFFF}));
  EXPECT_FALSE(identify({0x182, 0x0BE0, 0, 0xFFFFFFFF, 0, 0x12345677}));
  EXPECT_FALSE(identify({0x182, 0x0BE0, 0x00010004, 0xFFFFFFFF, 0, 0xFFFFFFFF}));
  EXPECT_FALSE(identify({0x182, 0x0BF3, 0, 0xFFFFFFFF, 0, 0xFFFFFFFF}));
  EXPECT_FALSE(identify({0x183, 0x0BE0, 0, 0xFFFFFFFF, 0, 0xFFFFFFFF}));
  // Not in waiting state: no answer.
  to_configuration(s);
  EXPECT_FALSE(identify({0x182, 0x0BE0, 0, 0xFFFFFFFF, 0, 0xFFFFFFFF}));
}

// CiA 305 identify non-configured remote slave 0x4C -> 0x50, only with
// node-ID FFh (active and pending).
TEST_F(LssSlaveTest, CiA305_IdentifyNonConfigured) {
  LssSlave configured = make(kJAddress, 127);
  configured.on_frame(lss_tx({0x4C, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_TRUE(sink.frames.empty());
  LssSlave fresh = make(kJAddress, 0xFF);
  fresh.on_frame(lss_tx({0x4C, 0, 0, 0, 0, 0, 0, 0}));
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0], lss_rx({0x50, 0, 0, 0, 0, 0, 0, 0}));
}

// J§1 intro: the rotary series claims DSP-305 V1.1.2, which has no Fastscan
// (J§1 intro): even unconfigured it never answers 0x51.
TEST_F(LssSlaveTest, J1_RotaryNeverAnswersFastscan) {
  LssSlave s = make(kJAddress, 0xFF, LssSlave::Features::rotary_j());
  EXPECT_FALSE(s.on_frame(lss_frame(0x7E5, 0x51, 0, kLssFastscanReset, 0, 0)));
  for (uint8_t bit = 31;; --bit) {
    EXPECT_FALSE(s.on_frame(lss_frame(0x7E5, 0x51, 0, bit, 0, 0)));
    if (bit == 0) break;
  }
  EXPECT_TRUE(sink.frames.empty());
}

// CiA 305 V3 Fastscan: answered only while active and pending
// node-ID are both FFh and the slave is waiting.
TEST_F(LssSlaveTest, CiA305_FastscanOnlyWhileUnconfigured) {
  LssSlave configured = make(kJAddress, 127);
  configured.on_frame(lss_frame(0x7E5, 0x51, 0, kLssFastscanReset, 0, 0));
  EXPECT_TRUE(sink.frames.empty());

  LssSlave fresh = make(kJAddress, 0xFF);
  fresh.on_frame(lss_frame(0x7E5, 0x51, 0, kLssFastscanReset, 0, 0));
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0], lss_rx({0x4F, 0, 0, 0, 0, 0, 0, 0}));
}

// CiA 305 Fastscan: bits 31..BitChecked compared; confirming the serial with
// LSSNext 0 puts the slave into configuration state.
TEST_F(LssSlaveTest, CiA305_FastscanBitCompareAndConfirm) {
  LssSlave s = make(kJAddress, 0xFF);
  auto answered = [&](uint32_t id, uint8_t bit, uint8_t sub, uint8_t next) {
    sink.frames.clear();
    s.on_frame(lss_frame(0x7E5, 0x51, id, bit, sub, next));
    return !sink.frames.empty();
  };
  EXPECT_TRUE(answered(0, kLssFastscanReset, 0, 0));
  EXPECT_TRUE(answered(0x00000000, 31, 0, 0));   // vendor bit 31 is 0
  EXPECT_FALSE(answered(0x00000000, 8, 0, 0));   // vendor 0x182 has bit 8 set
  EXPECT_TRUE(answered(0x00000100, 8, 0, 0));
  EXPECT_FALSE(answered(0x00000182, 0, 1, 2));   // still on the vendor: product frames ignored
  EXPECT_TRUE(answered(0x00000182, 0, 0, 1));    // confirm vendor, go to product
  EXPECT_TRUE(answered(0x00000BE0, 0, 1, 2));
  EXPECT_TRUE(answered(0x00010003, 0, 2, 3));
  EXPECT_EQ(s.mode(), LssMode::kWaiting);
  EXPECT_FALSE(answered(0x12345679, 0, 3, 0));
  EXPECT_EQ(s.mode(), LssMode::kWaiting);
  EXPECT_TRUE(answered(0x12345678, 0, 3, 0));
  EXPECT_EQ(s.mode(), LssMode::kConfiguration);
}

// CiA 305 V3: a slave without active node-ID that leaves configuration with
// a valid pending node-ID asks its owner for reset communication.
TEST_F(LssSlaveTest, CiA305_ResetCommunicationRequestAfterFirstConfiguration) {
  LssSlave s = make(kJAddress, 0xFF);
  to_configuration(s);
  s.on_frame(lss_tx({0x11, 0x21, 0, 0, 0, 0, 0, 0}));
  EXPECT_FALSE(s.take_reset_communication_request());
  s.on_frame(lss_tx({0x04, 0x00, 0, 0, 0, 0, 0, 0}));
  EXPECT_TRUE(s.take_reset_communication_request());
  EXPECT_FALSE(s.take_reset_communication_request());
  s.activate_pending();
  EXPECT_EQ(s.active_node_id(), 0x21);

  // Already configured: a node-ID change waits for an explicit reset.
  to_configuration(s);
  s.on_frame(lss_tx({0x11, 0x22, 0, 0, 0, 0, 0, 0}));
  s.on_frame(lss_tx({0x04, 0x00, 0, 0, 0, 0, 0, 0}));
  EXPECT_FALSE(s.take_reset_communication_request());
}

}  // namespace
}  // namespace cobridge::canopen
