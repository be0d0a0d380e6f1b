// StandbyListener: what a standby learns from the master's traffic alone
// (heartbeats, CiA 301 7.2.8.3.2; the identity object 0x1018 read by
// expedited SDO upload, CiA 301 7.2.4.3.2/7.2.4.3.3 and 7.5.2.36), and what
// it refuses: an answer nobody on the bus asked for.
#include "bus/standby_listener.hpp"

#include <gtest/gtest.h>

#include <cstdint>

namespace cobridge::bus {
namespace {

using namespace std::chrono_literals;
using canopen::TimePoint;
using Kind = StandbyListener::Heard::Kind;

constexpr auto kTimeout = 500ms;
const TimePoint t0{1000s};

can::Frame upload_request(std::uint8_t node, std::uint8_t sub, std::uint16_t index = 0x1018) {
  return can::Frame::make(0x600u + node, {0x40, static_cast<std::uint8_t>(index), static_cast<std::uint8_t>(index >> 8),
                                          sub, 0, 0, 0, 0});
}

can::Frame upload_answer(std::uint8_t node, std::uint8_t sub, std::uint32_t v, std::uint16_t index = 0x1018) {
  return can::Frame::make(0x580u + node,
                          {0x43, static_cast<std::uint8_t>(index), static_cast<std::uint8_t>(index >> 8), sub,
                           static_cast<std::uint8_t>(v), static_cast<std::uint8_t>(v >> 8),
                           static_cast<std::uint8_t>(v >> 16), static_cast<std::uint8_t>(v >> 24)});
}

// The master's four reads of node `node`'s identity, each answered at once.
StandbyListener::Heard read_identity(StandbyListener& l, std::uint8_t node, canopen::LssAddress id, TimePoint at) {
  const std::uint32_t values[] = {id.vendor, id.product, id.revision, id.serial};
  StandbyListener::Heard last;
  for (std::uint8_t sub = 1; sub <= 4; ++sub) {
    EXPECT_EQ(l.hear(upload_request(node, sub), at, kTimeout).kind, Kind::nothing);
    last = l.hear(upload_answer(node, sub, values[sub - 1]), at + 2ms, kTimeout);
    if (sub < 4) {
      EXPECT_EQ(last.kind, Kind::nothing) << "sub " << int(sub);
    }
  }
  return last;
}

TEST(StandbyListener, Cia301_7_2_8_3_2_HeartbeatTellsTheNodesState) {
  StandbyListener l;
  auto h = l.hear(can::Frame::make(0x705, {0x05}), t0, kTimeout);
  EXPECT_EQ(h.kind, Kind::state);
  EXPECT_EQ(h.node, 5);
  EXPECT_TRUE(h.operational);
  h = l.hear(can::Frame::make(0x705, {0x85}), t0, kTimeout);  // guarding toggle bit set
  EXPECT_TRUE(h.operational);
  h = l.hear(can::Frame::make(0x77F, {0x7F}), t0, kTimeout);
  EXPECT_EQ(h.kind, Kind::state);
  EXPECT_EQ(h.node, 127);
  EXPECT_FALSE(h.operational);
  EXPECT_EQ(l.hear(can::Frame::make(0x705, {0x05, 0x00}), t0, kTimeout).kind, Kind::nothing) << "two bytes";
  EXPECT_EQ(l.hear(can::Frame::make(0x700, {0x05}), t0, kTimeout).kind, Kind::nothing) << "node 0";
}

TEST(StandbyListener, Cia301_7_5_2_36_IdentityReadByTheMasterPlacesTheNode) {
  StandbyListener l;
  const canopen::LssAddress id{0x0000023A, 0x00000BC7, 0x00010002, 12345678};
  const auto h = read_identity(l, 9, id, t0);
  ASSERT_EQ(h.kind, Kind::identity);
  EXPECT_EQ(h.node, 9);
  EXPECT_EQ(h.identity.vendor, id.vendor);
  EXPECT_EQ(h.identity.product, id.product);
  EXPECT_EQ(h.identity.revision, id.revision);
  EXPECT_EQ(h.identity.serial, id.serial);
}

TEST(StandbyListener, Cia301_7_2_4_3_3_AnswerNobodyAskedForIsIgnored) {
  StandbyListener l;
  EXPECT_EQ(l.hear(upload_answer(9, 4, 777), t0, kTimeout).kind, Kind::nothing) << "no request at all";
  (void)l.hear(upload_request(9, 3), t0, kTimeout);
  EXPECT_EQ(l.hear(upload_answer(9, 4, 777), t0, kTimeout).kind, Kind::nothing) << "another sub-index asked";
  (void)l.hear(upload_request(8, 4), t0, kTimeout);
  EXPECT_EQ(l.hear(upload_answer(9, 4, 777), t0, kTimeout).kind, Kind::nothing) << "another node asked";
  (void)l.hear(upload_request(9, 4), t0, kTimeout);
  EXPECT_EQ(l.hear(upload_answer(9, 4, 777), t0 + kTimeout + 1ms, kTimeout).kind, Kind::nothing)
      << "answer after the SDO timeout";
}

TEST(StandbyListener, Cia301_7_2_4_3_3_OneRequestCountsForOneAnswer) {
  StandbyListener l;
  (void)l.hear(upload_request(9, 4), t0, kTimeout);
  EXPECT_EQ(l.hear(upload_answer(9, 4, 777), t0 + 1ms, kTimeout).kind, Kind::identity);
  EXPECT_EQ(l.hear(upload_answer(9, 4, 778), t0 + 2ms, kTimeout).kind, Kind::nothing) << "a second answer, forged";
}

TEST(StandbyListener, Cia301_7_2_4_3_2_AnotherUploadForgetsTheIdentityRequest) {
  StandbyListener l;
  (void)l.hear(upload_request(9, 4), t0, kTimeout);
  (void)l.hear(upload_request(9, 0, 0x1017), t0 + 1ms, kTimeout);
  EXPECT_EQ(l.hear(upload_answer(9, 4, 777), t0 + 2ms, kTimeout).kind, Kind::nothing);
}

TEST(StandbyListener, NonExpeditedOrOtherObjectAnswersTellNothing) {
  StandbyListener l;
  (void)l.hear(upload_request(9, 4), t0, kTimeout);
  auto segmented = upload_answer(9, 4, 777);
  segmented.data[0] = 0x41;  // size indicated, not expedited
  EXPECT_EQ(l.hear(segmented, t0 + 1ms, kTimeout).kind, Kind::nothing);
  EXPECT_EQ(l.hear(upload_answer(9, 0, 0x1234, 0x1017), t0 + 1ms, kTimeout).kind, Kind::nothing);
  auto extended = can::Frame::make(0x705, {0x05});
  extended.flags = can::Frame::kFlagExtended;
  EXPECT_EQ(l.hear(extended, t0, kTimeout).kind, Kind::nothing);
}

}  // namespace
}  // namespace cobridge::bus
