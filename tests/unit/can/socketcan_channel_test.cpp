// can::SocketCanChannel parts that need no CAN socket: the kernel
// representations (kernel can.rst "RAW socket option CAN_RAW_FILTER",
// include/uapi/linux/can.h) and behaviour while closed.
#include "can/socketcan_channel.hpp"

#include <gtest/gtest.h>
#include <linux/can.h>

#include <array>

namespace {

using cobridge::Errc;
using cobridge::Error;
using cobridge::can::Filter;
using cobridge::can::Frame;
using cobridge::can::from_linux;
using cobridge::can::SocketCanChannel;
using cobridge::can::SocketCanConfig;
using cobridge::can::to_linux;

// can.h: 11-bit frames carry the id in CAN_SFF_MASK, 29-bit ones set CAN_EFF_FLAG, RTR sets CAN_RTR_FLAG.
TEST(SocketCanFrame, CanH_StandardExtendedAndRtrIdentifiers) {
  const can_frame sff = to_linux(Frame::make(0x581, {0x43, 0x00, 0x10}));
  EXPECT_EQ(sff.can_id, 0x581u);
  EXPECT_EQ(sff.len, 3);
  EXPECT_EQ(sff.data[0], 0x43);

  Frame ext = Frame::make(0x18FF1234, {1});
  ext.flags = Frame::kFlagExtended;
  EXPECT_EQ(to_linux(ext).can_id, 0x18FF1234u | CAN_EFF_FLAG);

  Frame rtr = Frame::make(0x701, {});
  rtr.flags = Frame::kFlagRtr;
  EXPECT_EQ(to_linux(rtr).can_id, 0x701u | CAN_RTR_FLAG);

  // An 11-bit frame never leaks bits above CAN_SFF_MASK.
  EXPECT_EQ(to_linux(Frame::make(0xF581, {})).can_id, 0x581u);
}

// can.h / error.h: an error frame is CAN_ERR_FLAG plus class bits; round trip keeps the class bits.
TEST(SocketCanFrame, CanH_ErrorFrameRoundTrip) {
  Frame err = Frame::make8(0x40 /*CAN_ERR_BUSOFF*/, {0, 0x20, 0, 0, 0, 0, 0, 0});
  err.flags = Frame::kFlagError;
  const can_frame cf = to_linux(err);
  EXPECT_EQ(cf.can_id, 0x40u | CAN_ERR_FLAG);
  const Frame back = from_linux(cf, 42);
  EXPECT_TRUE(back.is_error());
  EXPECT_EQ(back.id, 0x40u);
  EXPECT_EQ(back.timestamp_ns, 42);
  EXPECT_EQ(back, err);
}

TEST(SocketCanFrame, CanH_FromLinuxClampsLengthAndKeepsTimestamp) {
  can_frame cf{};
  cf.can_id = 0x12345678u | CAN_EFF_FLAG;
  cf.len = 15;  // malformed: more than CAN_MAX_DLEN
  const Frame f = from_linux(cf, 1'700'000'000'000'000'000);
  EXPECT_TRUE(f.is_extended());
  EXPECT_EQ(f.id, 0x12345678u);
  EXPECT_EQ(f.len, 8);
  EXPECT_EQ(f.timestamp_ns, 1'700'000'000'000'000'000);
}

// can.rst CAN_RAW_FILTER: <received_can_id> & mask == can_id & mask; we add CAN_EFF_FLAG to the mask
// so the frame format is part of the match.
TEST(SocketCanFilter, CanRst_RawFilterMatchesFormatToo) {
  const can_filter f = to_linux(Filter::exact(0x181));
  EXPECT_EQ(f.can_id, 0x181u);
  EXPECT_EQ(f.can_mask, CAN_SFF_MASK | CAN_EFF_FLAG);
  const can_filter e = to_linux(Filter{0x18FF0000, 0x1FFF0000, true});
  EXPECT_EQ(e.can_id, 0x18FF0000u | CAN_EFF_FLAG);
  EXPECT_EQ(e.can_mask, 0x1FFF0000u | CAN_EFF_FLAG);
  // A 29-bit frame whose low 11 bits are 0x181 does not pass the 11-bit filter.
  const canid_t ext_id = 0x00000181u | CAN_EFF_FLAG;
  EXPECT_NE(ext_id & f.can_mask, f.can_id & f.can_mask);
}

// A channel that is not open drops sends (FrameSink contract: false, counted) and reads nothing.
TEST(SocketCanChannelClosed, SendFailsAndCountsReceiveIsEmpty) {
  SocketCanChannel ch(SocketCanConfig{.interface = "vcan0"});
  EXPECT_FALSE(ch.is_open());
  EXPECT_EQ(ch.fd(), -1);
  EXPECT_FALSE(ch.send(Frame::make(0x80, {})));
  EXPECT_EQ(ch.stats().tx_dropped, 1u);
  std::array<Frame, 4> buf{};
  EXPECT_EQ(ch.receive(buf), 0u);
  // Never opened: nothing to retry.
  EXPECT_EQ(ch.process(SocketCanChannel::Clock::now()), SocketCanChannel::TimePoint::max());
  EXPECT_TRUE(ch.take_events().empty());
}

// Opening an interface that does not exist (or on a kernel without CAN, as on the build host)
// fails with the project's Error: kind unavailable, the errno as precise code, the
// failing step as message, the interface as where.
TEST(SocketCanChannelClosed, OpenFailureCarriesCodeMessageAndWhere) {
  SocketCanChannel ch(SocketCanConfig{.interface = "cbx-none0"});
  const Error err = ch.open();
  ASSERT_TRUE(err);
  EXPECT_EQ(err.kind, Errc::kUnavailable);
  EXPECT_NE(err.code.value(), 0);
  EXPECT_EQ(err.code.category(), std::system_category());
  EXPECT_EQ(err.where, "cbx-none0");
  EXPECT_FALSE(err.message.empty());
  EXPECT_EQ(err.message.find("cbx-none0"), std::string::npos) << "where is not repeated: " << err.message;
  EXPECT_EQ(err.to_string().rfind("cbx-none0: ", 0), 0u) << err.to_string();
  EXPECT_FALSE(ch.is_open());
  EXPECT_EQ(ch.process(SocketCanChannel::Clock::now()), SocketCanChannel::TimePoint::max());
}

TEST(SocketCanChannelClosed, OverlongInterfaceNameIsRejected) {
  SocketCanChannel ch(SocketCanConfig{.interface = "an-interface-name-longer-than-ifnamsiz"});
  const Error err = ch.open();
  ASSERT_TRUE(err);
  EXPECT_EQ(err.kind, Errc::kInvalidArgument) << "a name no interface can have is bad input";
  EXPECT_EQ(err.code, std::error_code(ENODEV, std::system_category()));
  EXPECT_EQ(err.where, "an-interface-name-longer-than-ifnamsiz");
  EXPECT_NE(err.message.find("IFNAMSIZ"), std::string::npos) << err.message;
}

}  // namespace
