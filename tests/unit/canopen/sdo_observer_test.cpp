// Another client's SDO downloads, followed from the side (CiA 301
// §7.2.4.3.3 download initiate, §7.2.4.3.4 download segment, §7.2.4.3.17
// abort): a write counts once the server confirmed it.
#include "canopen/sdo_observer.hpp"

#include <gtest/gtest.h>

#include <initializer_list>

namespace cobridge::canopen {
namespace {

using namespace std::chrono_literals;
const TimePoint kT0{std::chrono::seconds(100)};

can::Frame frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  can::Frame f;
  f.id = id;
  f.len = 8;
  std::size_t i = 0;
  for (const auto b : bytes) f.data[i++] = b;
  return f;
}

// Feeds the frames in order at kT0; none of them may complete a write.
void feed_without_write(SdoObserver& o, std::initializer_list<can::Frame> frames) {
  std::size_t i = 0;
  for (const auto& f : frames) {
    EXPECT_FALSE(o.on_frame(f, kT0)) << "frame " << i << " completed a write";
    ++i;
  }
}

TEST(SdoObserver, AnExpeditedDownloadCountsWhenTheServerConfirmsIt) {
  SdoObserver o;
  // 0x1017:00 = 9029 (0x2345), 2 bytes indicated (0x2B), node 5.
  EXPECT_FALSE(o.on_frame(frame(0x605, {0x2B, 0x17, 0x10, 0x00, 0x45, 0x23, 0, 0}), kT0));
  const auto w = o.on_frame(frame(0x585, {0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0}), kT0 + 5ms);
  ASSERT_TRUE(w);
  EXPECT_EQ(w->node, 5);
  EXPECT_EQ(w->index, 0x1017);
  EXPECT_EQ(w->sub, 0);
  ASSERT_EQ(w->size, 2);
  EXPECT_EQ(w->data[0], 0x45);
  EXPECT_EQ(w->data[1], 0x23);
  EXPECT_FALSE(o.on_frame(frame(0x585, {0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0}), kT0 + 6ms));  // once
}

TEST(SdoObserver, NoWriteWithoutTheConfirmation) {
  SdoObserver o;
  const auto req = frame(0x605, {0x23, 0x00, 0x18, 0x05, 0x64, 0, 0, 0});
  // Aborted by the server.
  EXPECT_FALSE(o.on_frame(req, kT0));
  EXPECT_FALSE(o.on_frame(frame(0x585, {0x80, 0x00, 0x18, 0x05, 0x02, 0x00, 0x01, 0x06}), kT0));
  EXPECT_FALSE(o.on_frame(frame(0x585, {0x60, 0x00, 0x18, 0x05, 0, 0, 0, 0}), kT0));
  // Confirmed too late, or for another object, or by another node.
  EXPECT_FALSE(o.on_frame(req, kT0));
  EXPECT_FALSE(o.on_frame(frame(0x585, {0x60, 0x00, 0x18, 0x05, 0, 0, 0, 0}), kT0 + 1001ms));
  EXPECT_FALSE(o.on_frame(req, kT0));
  EXPECT_FALSE(o.on_frame(frame(0x585, {0x60, 0x00, 0x18, 0x01, 0, 0, 0, 0}), kT0));
  EXPECT_FALSE(o.on_frame(frame(0x586, {0x60, 0x00, 0x18, 0x05, 0, 0, 0, 0}), kT0));
  // An upload's answer is no write.
  EXPECT_FALSE(o.on_frame(frame(0x607, {0x40, 0x17, 0x10, 0x00, 0, 0, 0, 0}), kT0));
  EXPECT_FALSE(o.on_frame(frame(0x587, {0x4B, 0x17, 0x10, 0x00, 0x64, 0, 0, 0}), kT0));
  // A response nobody asked for (the gateway's own transfer: its requests never reach this socket).
  EXPECT_FALSE(o.on_frame(frame(0x588, {0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0}), kT0));
}

TEST(SdoObserver, ASegmentedDownloadCountsAtTheLastSegmentsConfirmation) {
  SdoObserver o;
  // 0x2000:01, 9 bytes in two segments (7, then 2 with n = 5 and c = 1).
  feed_without_write(o, {frame(0x60A, {0x21, 0x00, 0x20, 0x01, 9, 0, 0, 0}),
                         frame(0x58A, {0x60, 0x00, 0x20, 0x01, 0, 0, 0, 0}),
                         frame(0x60A, {0x00, 1, 2, 3, 4, 5, 6, 7}),
                         frame(0x58A, {0x20, 0, 0, 0, 0, 0, 0, 0}),
                         frame(0x60A, {0x1B, 8, 9, 0, 0, 0, 0, 0})});
  const auto w = o.on_frame(frame(0x58A, {0x30, 0, 0, 0, 0, 0, 0, 0}), kT0);
  ASSERT_TRUE(w);
  EXPECT_EQ(w->index, 0x2000);
  EXPECT_EQ(w->sub, 1);
  EXPECT_EQ(w->total, 9U);
  ASSERT_EQ(w->size, SdoObserver::kKeptBytes);
  EXPECT_EQ(w->data[0], 1);
  EXPECT_EQ(w->data[7], 8);
}

// §7.2.4.3.9..§7.2.4.3.14: 0x1017:00 = 9029 in a block download (as a
// tool that writes every object by block does): initiate (size 2), one
// segment (c = 1, seqno 1), block ack 1, end with n = 5, end response.
TEST(SdoObserver, ABlockDownloadCountsAtTheEndResponse) {
  SdoObserver o;
  feed_without_write(o, {frame(0x605, {0xC6, 0x17, 0x10, 0x00, 2, 0, 0, 0}),
                         frame(0x585, {0xA4, 0x17, 0x10, 0x00, 127, 0, 0, 0}),
                         frame(0x605, {0x81, 0x45, 0x23, 0, 0, 0, 0, 0}),
                         frame(0x585, {0xA2, 1, 127, 0, 0, 0, 0, 0}),
                         frame(0x605, {0xC1 | (5 << 2), 0x12, 0x34, 0, 0, 0, 0, 0})});
  const auto w = o.on_frame(frame(0x585, {0xA1, 0, 0, 0, 0, 0, 0, 0}), kT0 + 2ms);
  ASSERT_TRUE(w);
  EXPECT_EQ(w->node, 5);
  EXPECT_EQ(w->index, 0x1017);
  EXPECT_EQ(w->total, 2U);
  ASSERT_EQ(w->size, 2);
  EXPECT_EQ(w->data[0], 0x45);
  EXPECT_EQ(w->data[1], 0x23);
}

// A sub-block the server took only in part (ackseq 1 of 2: it did not take
// the second segment, which this socket saw) is sent again from there,
// seqno 1 again; a segment out of order is ignored, as the server ignores
// it. 10 bytes in all. A segment whose byte 0 reads like an expedited
// initiate (0x23: seqno 35) starts nothing while the block runs.
TEST(SdoObserver, ABlockDownloadFollowsTheSegmentsTheServerTook) {
  SdoObserver o;
  feed_without_write(o, {frame(0x60A, {0xC2, 0x00, 0x20, 0x01, 0, 0, 0, 0}),
                         frame(0x58A, {0xA0, 0x00, 0x20, 0x01, 2, 0, 0, 0}),
                         frame(0x60A, {0x01, 1, 2, 3, 4, 5, 6, 7}),
                         frame(0x60A, {0x02, 0xEE, 0xEE, 0xEE, 0xEE, 0xEE, 0xEE, 0xEE}),  // not taken
                         frame(0x58A, {0xA2, 1, 2, 0, 0, 0, 0, 0}),
                         frame(0x60A, {0x03, 0xDD, 0xDD, 0xDD, 0xDD, 0xDD, 0xDD, 0xDD}),  // out of order
                         frame(0x60A, {0x81, 8, 9, 10, 0, 0, 0, 0}),
                         frame(0x58A, {0xA2, 1, 2, 0, 0, 0, 0, 0}),
                         frame(0x60A, {0xC1 | (4 << 2), 0, 0, 0, 0, 0, 0, 0})});
  const auto w = o.on_frame(frame(0x58A, {0xA1, 0, 0, 0, 0, 0, 0, 0}), kT0);
  ASSERT_TRUE(w);
  EXPECT_EQ(w->index, 0x2000);
  EXPECT_EQ(w->total, 10U);
  ASSERT_EQ(w->size, SdoObserver::kKeptBytes);
  EXPECT_EQ(w->data[6], 7);
  EXPECT_EQ(w->data[7], 8);

  feed_without_write(o, {frame(0x60A, {0xC2, 0x17, 0x10, 0x00, 0, 0, 0, 0}),
                         frame(0x58A, {0xA0, 0x17, 0x10, 0x00, 4, 0, 0, 0}),
                         frame(0x60A, {0x23, 0x17, 0x10, 0x00, 1, 0, 0, 0}),  // a segment, seqno 35
                         frame(0x58A, {0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0})});
}

// An abort (cs 4, byte 0 = 0x80) ends a block download unconfirmed.
TEST(SdoObserver, AnAbortedBlockDownloadIsNoWrite) {
  SdoObserver o;
  feed_without_write(o, {frame(0x605, {0xC6, 0x17, 0x10, 0x00, 2, 0, 0, 0}),
                         frame(0x585, {0xA4, 0x17, 0x10, 0x00, 127, 0, 0, 0}),
                         frame(0x605, {0x80, 0x17, 0x10, 0x00, 0, 0, 4, 5}),
                         frame(0x585, {0xA2, 1, 127, 0, 0, 0, 0, 0}),
                         frame(0x605, {0xC1 | (5 << 2), 0, 0, 0, 0, 0, 0, 0}),
                         frame(0x585, {0xA1, 0, 0, 0, 0, 0, 0, 0})});
}

TEST(SdoObserver, OddFramesAreIgnored) {
  SdoObserver o;
  can::Frame rtr = frame(0x605, {0x2B, 0x17, 0x10, 0x00, 0x45, 0x23, 0, 0});
  rtr.flags = can::Frame::kFlagRtr;
  EXPECT_FALSE(o.on_frame(rtr, kT0));
  can::Frame shortf = frame(0x605, {0x2B, 0x17, 0x10});
  shortf.len = 3;
  EXPECT_FALSE(o.on_frame(shortf, kT0));
  EXPECT_FALSE(o.on_frame(frame(0x600, {0x2B, 0x17, 0x10, 0x00, 0x45, 0x23, 0, 0}), kT0));  // node 0
  EXPECT_FALSE(o.on_frame(frame(0x585, {0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0}), kT0));
}

}  // namespace
}  // namespace cobridge::canopen
