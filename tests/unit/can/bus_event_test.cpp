// can::decode_error_frame against the Linux error frame layout
// (include/uapi/linux/can/error.h: class bits in can_id, details in data[]).
#include "can/bus_event.hpp"

#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/error.h>

#include <array>
#include <vector>

namespace {

using cobridge::can::BusEvent;
using cobridge::can::BusEventKind;
using cobridge::can::decode_error_frame;
using cobridge::can::Frame;
using cobridge::can::kMaxEventsPerErrorFrame;

Frame error_frame(uint32_t classes, std::array<uint8_t, 8> data = {}) {
  Frame f = Frame::make8(classes, data);
  f.flags = Frame::kFlagError;
  f.timestamp_ns = 1'700'000'000'123'456'789;
  return f;
}

std::vector<BusEventKind> kinds(const Frame& f) {
  std::array<BusEvent, kMaxEventsPerErrorFrame> out{};
  const std::size_t n = decode_error_frame(f, out);
  std::vector<BusEventKind> k;
  for (std::size_t i = 0; i < n; ++i) k.push_back(out[i].kind);
  return k;
}

// error.h: CAN_ERR_BUSOFF (0x40) - ISO 11898-1 fault confinement, TEC > 255.
TEST(BusEvent, ErrorH_BusOffClassBit) {
  EXPECT_EQ(kinds(error_frame(CAN_ERR_BUSOFF)), std::vector{BusEventKind::BusOff});
}

// error.h: CAN_ERR_CRTL with data[1] CAN_ERR_CRTL_TX_PASSIVE / RX_PASSIVE - ISO 11898-1 counter >= 128.
TEST(BusEvent, ErrorH_ControllerPassiveFromData1) {
  std::array<BusEvent, kMaxEventsPerErrorFrame> out{};
  const Frame f = error_frame(CAN_ERR_CRTL, {0, CAN_ERR_CRTL_TX_PASSIVE, 0, 0, 0, 0, 0, 0});
  ASSERT_EQ(decode_error_frame(f, out), 1u);
  EXPECT_EQ(out[0].kind, BusEventKind::ErrorPassive);
  EXPECT_EQ(out[0].info, CAN_ERR_CRTL_TX_PASSIVE);  // wire byte kept for the log
  EXPECT_EQ(out[0].timestamp_ns, f.timestamp_ns);
  EXPECT_EQ(kinds(error_frame(CAN_ERR_CRTL, {0, CAN_ERR_CRTL_RX_PASSIVE, 0, 0, 0, 0, 0, 0})),
            std::vector{BusEventKind::ErrorPassive});
}

// error.h: data[1] CAN_ERR_CRTL_{RX,TX}_WARNING - ISO 11898-1 warning limit 96; CAN_ERR_CRTL_ACTIVE.
TEST(BusEvent, ErrorH_ControllerWarningAndActive) {
  EXPECT_EQ(kinds(error_frame(CAN_ERR_CRTL, {0, CAN_ERR_CRTL_RX_WARNING, 0, 0, 0, 0, 0, 0})),
            std::vector{BusEventKind::ErrorWarning});
  EXPECT_EQ(kinds(error_frame(CAN_ERR_CRTL, {0, CAN_ERR_CRTL_TX_WARNING, 0, 0, 0, 0, 0, 0})),
            std::vector{BusEventKind::ErrorWarning});
  EXPECT_EQ(kinds(error_frame(CAN_ERR_CRTL, {0, CAN_ERR_CRTL_ACTIVE, 0, 0, 0, 0, 0, 0})),
            std::vector{BusEventKind::ErrorActive});
}

// error.h: data[1] CAN_ERR_CRTL_RX_OVERFLOW / TX_OVERFLOW; CAN_ERR_CRTL_UNSPEC.
TEST(BusEvent, ErrorH_ControllerOverflowsAndUnspecified) {
  EXPECT_EQ(kinds(error_frame(CAN_ERR_CRTL, {0, CAN_ERR_CRTL_RX_OVERFLOW | CAN_ERR_CRTL_TX_OVERFLOW, 0, 0, 0, 0, 0, 0})),
            (std::vector{BusEventKind::ControllerRxOverflow, BusEventKind::ControllerTxOverflow}));
  EXPECT_EQ(kinds(error_frame(CAN_ERR_CRTL)), std::vector{BusEventKind::ControllerProblem});
}

// error.h: CAN_ERR_PROT with type data[2] and location data[3].
TEST(BusEvent, ErrorH_ProtocolViolationKeepsTypeAndLocation) {
  std::array<BusEvent, kMaxEventsPerErrorFrame> out{};
  const Frame f = error_frame(CAN_ERR_PROT, {0, 0, CAN_ERR_PROT_STUFF, CAN_ERR_PROT_LOC_DATA, 0, 0, 0, 0});
  ASSERT_EQ(decode_error_frame(f, out), 1u);
  EXPECT_EQ(out[0].kind, BusEventKind::ProtocolViolation);
  EXPECT_EQ(out[0].info, CAN_ERR_PROT_STUFF);
  EXPECT_EQ(out[0].location, CAN_ERR_PROT_LOC_DATA);
}

// error.h: CAN_ERR_TRX data[4], CAN_ERR_ACK, CAN_ERR_LOSTARB data[0], TX_TIMEOUT, BUSERROR, RESTARTED.
TEST(BusEvent, ErrorH_RemainingClasses) {
  std::array<BusEvent, kMaxEventsPerErrorFrame> out{};
  ASSERT_EQ(decode_error_frame(error_frame(CAN_ERR_TRX, {0, 0, 0, 0, CAN_ERR_TRX_CANH_NO_WIRE, 0, 0, 0}), out), 1u);
  EXPECT_EQ(out[0].kind, BusEventKind::Transceiver);
  EXPECT_EQ(out[0].info, CAN_ERR_TRX_CANH_NO_WIRE);
  ASSERT_EQ(decode_error_frame(error_frame(CAN_ERR_LOSTARB, {5, 0, 0, 0, 0, 0, 0, 0}), out), 1u);
  EXPECT_EQ(out[0].kind, BusEventKind::LostArbitration);
  EXPECT_EQ(out[0].info, 5);
  EXPECT_EQ(kinds(error_frame(CAN_ERR_ACK)), std::vector{BusEventKind::AckMissing});
  EXPECT_EQ(kinds(error_frame(CAN_ERR_TX_TIMEOUT)), std::vector{BusEventKind::TxTimeout});
  EXPECT_EQ(kinds(error_frame(CAN_ERR_BUSERROR)), std::vector{BusEventKind::BusError});
  EXPECT_EQ(kinds(error_frame(CAN_ERR_RESTARTED)), std::vector{BusEventKind::Restarted});
}

// error.h: several classes in one frame; CAN_ERR_CNT puts TEC/REC in data[6]/data[7]. Bus state comes first.
TEST(BusEvent, ErrorH_CombinedFrameWithCounters) {
  std::array<BusEvent, kMaxEventsPerErrorFrame> out{};
  const Frame f = error_frame(CAN_ERR_ACK | CAN_ERR_CRTL | CAN_ERR_BUSOFF | CAN_ERR_CNT,
                              {0, CAN_ERR_CRTL_TX_PASSIVE, 0, 0, 0, 0, 200, 17});
  const std::size_t n = decode_error_frame(f, out);
  ASSERT_EQ(n, 3u);
  EXPECT_EQ(out[0].kind, BusEventKind::BusOff);
  EXPECT_EQ(out[1].kind, BusEventKind::ErrorPassive);
  EXPECT_EQ(out[2].kind, BusEventKind::AckMissing);
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_TRUE(out[i].has_counters);
    EXPECT_EQ(out[i].tx_error_count, 200);
    EXPECT_EQ(out[i].rx_error_count, 17);
  }
  // Without CAN_ERR_CNT data[6..7] are not counters.
  ASSERT_EQ(decode_error_frame(error_frame(CAN_ERR_BUSOFF, {0, 0, 0, 0, 0, 0, 200, 17}), out), 1u);
  EXPECT_FALSE(out[0].has_counters);
}

// The decoder never writes past the caller's span, and ignores data frames.
TEST(BusEvent, ErrorH_RespectsOutputSizeAndIgnoresDataFrames) {
  std::array<BusEvent, 1> one{};
  const Frame f = error_frame(CAN_ERR_BUSOFF | CAN_ERR_ACK);
  EXPECT_EQ(decode_error_frame(f, one), 1u);
  EXPECT_EQ(one[0].kind, BusEventKind::BusOff);
  std::array<BusEvent, kMaxEventsPerErrorFrame> out{};
  EXPECT_EQ(decode_error_frame(Frame::make(0x40, {0x01}), out), 0u);  // 0x40 == CAN_ERR_BUSOFF, but a data frame
  // Every bit at once stays within kMaxEventsPerErrorFrame.
  const std::size_t n = decode_error_frame(error_frame(CAN_ERR_MASK, {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0}), out);
  EXPECT_EQ(n, 13u);
}

TEST(BusEvent, ToStringNamesEveryKind) {
  EXPECT_EQ(to_string(BusEventKind::BusOff), "bus-off");
  EXPECT_EQ(to_string(BusEventKind::ErrorPassive), "error-passive");
  EXPECT_EQ(to_string(BusEventKind::InterfaceDown), "interface-down");
  EXPECT_EQ(to_string(BusEventKind::InterfaceReopened), "interface-reopened");
  for (int k = static_cast<int>(BusEventKind::ErrorWarning); k <= static_cast<int>(BusEventKind::InterfaceReopened); ++k)
    EXPECT_NE(to_string(static_cast<BusEventKind>(k)), "unknown") << k;
}

}  // namespace
