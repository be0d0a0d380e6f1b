#include "canopen/sync.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "recording_sink.hpp"

namespace cobridge::canopen {
namespace {

using namespace std::chrono_literals;
using can::Frame;

using test::RecordingSink;

class SyncProducerTest : public ::testing::Test {
 protected:
  TimePoint at(int ms) const { return t0 + std::chrono::milliseconds(ms); }
  SyncProducer producer;
  RecordingSink sink;
  const TimePoint t0 = TimePoint{} + 1h;
};

// CiA 301 §7.2.5.3: without counter (0x1019 = 0) the SYNC has no data; J§1.3.1
// 0x1005 default COB-ID 0x80; the period is 0x1006.
TEST_F(SyncProducerTest, CiA301_7_2_5_3_WithoutCounter) {
  ASSERT_FALSE(producer.configure({.cob_id = 0x80, .period = 10ms, .overflow = 0}));
  EXPECT_EQ(producer.process(at(0), sink), kNever);  // not started
  producer.start(at(0));
  EXPECT_EQ(producer.process(at(0), sink), at(10));
  EXPECT_TRUE(sink.frames.empty());
  EXPECT_EQ(producer.process(at(10), sink), at(20));
  EXPECT_EQ(producer.process(at(15), sink), at(20));
  EXPECT_EQ(producer.process(at(20), sink), at(30));
  ASSERT_EQ(sink.frames.size(), 2u);
  EXPECT_EQ(sink.frames[0], Frame::make(0x80, {}));
  EXPECT_EQ(sink.frames[1].len, 0);
  EXPECT_EQ(producer.sent(), 2u);
}

// CiA 301 §7.2.5.3 / 0x1019: counter 1..overflow, then back to 1.
TEST_F(SyncProducerTest, CiA301_1019_CounterWraps) {
  ASSERT_FALSE(producer.configure({.cob_id = 0x80, .period = 1ms, .overflow = 3}));
  producer.start(at(0));
  for (int i = 1; i <= 7; ++i) (void)producer.process(at(i), sink);
  std::vector<uint8_t> counters;
  for (const Frame& f : sink.frames) {
    EXPECT_EQ(f.len, 1);
    counters.push_back(f.data[0]);
  }
  EXPECT_EQ(counters, (std::vector<uint8_t>{1, 2, 3, 1, 2, 3, 1}));
}

// CiA 301 0x1019: overflow 240 is the largest allowed.
TEST_F(SyncProducerTest, CiA301_1019_Overflow240) {
  ASSERT_FALSE(producer.configure({.cob_id = 0x80, .period = 1ms, .overflow = 240}));
  producer.start(at(0));
  for (int i = 1; i <= 241; ++i) (void)producer.process(at(i), sink);
  ASSERT_EQ(sink.frames.size(), 241u);
  EXPECT_EQ(sink.frames[239].data[0], 240);
  EXPECT_EQ(sink.frames[240].data[0], 1);
}

// CiA 301 0x1019: 1 and 241..255 are reserved; 0x1005 is an 11-bit id here.
TEST_F(SyncProducerTest, CiA301_1019_InvalidConfigurations) {
  EXPECT_EQ(producer.configure({.cob_id = 0x80, .period = 1ms, .overflow = 1}),
            SyncConfigErrc::invalid_overflow);
  EXPECT_EQ(producer.configure({.cob_id = 0x80, .period = 1ms, .overflow = 241}),
            SyncConfigErrc::invalid_overflow);
  EXPECT_EQ(producer.configure({.cob_id = 0x80, .period = 0ms, .overflow = 0}),
            SyncConfigErrc::zero_period);
  const std::error_code ec = producer.configure({.cob_id = 0x800, .period = 1ms, .overflow = 0});
  EXPECT_EQ(ec, SyncConfigErrc::invalid_cob_id);
  EXPECT_EQ(std::string(ec.category().name()), "cobridge.sync");
  producer.start(at(0));
  EXPECT_FALSE(producer.running());  // a failed configure leaves it stopped
}

// J§1.3.1 / F§7.3 0x1005 is rw: the COB-ID is configurable.
TEST_F(SyncProducerTest, F7_3_ConfigurableCobId) {
  ASSERT_FALSE(producer.configure({.cob_id = 0x81, .period = 5ms, .overflow = 0}));
  producer.start(at(0));
  (void)producer.process(at(5), sink);
  ASSERT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(sink.frames[0].id, 0x81u);
}

// CiA 301 §7.2.5: SYNC is periodic; a late caller gets one SYNC, not a burst,
// and the period grid is kept.
TEST_F(SyncProducerTest, CiA301_7_2_5_LateCallerKeepsGrid) {
  ASSERT_FALSE(producer.configure({.cob_id = 0x80, .period = 10ms, .overflow = 0}));
  producer.start(at(0));
  EXPECT_EQ(producer.process(at(55), sink), at(60));
  EXPECT_EQ(sink.frames.size(), 1u);
  EXPECT_EQ(producer.process(at(60), sink), at(70));
  EXPECT_EQ(sink.frames.size(), 2u);
}

// A SYNC that could not be queued does not advance the counter (CiA 301
// §7.2.5.3: consumers see the counter increase by one per SYNC).
TEST_F(SyncProducerTest, CiA301_7_2_5_3_SendFailureKeepsCounter) {
  ASSERT_FALSE(producer.configure({.cob_id = 0x80, .period = 1ms, .overflow = 5}));
  producer.start(at(0));
  (void)producer.process(at(1), sink);
  sink.accept = false;
  (void)producer.process(at(2), sink);
  EXPECT_EQ(producer.send_failures(), 1u);
  EXPECT_EQ(producer.next_counter(), 2);
  sink.accept = true;
  (void)producer.process(at(3), sink);
  ASSERT_EQ(sink.frames.size(), 2u);
  EXPECT_EQ(sink.frames[1].data[0], 2);
}

// CiA 301 §7.2.5.3: the counter restarts at 1 when the producer restarts.
TEST_F(SyncProducerTest, CiA301_7_2_5_3_RestartResetsCounter) {
  ASSERT_FALSE(producer.configure({.cob_id = 0x80, .period = 1ms, .overflow = 5}));
  producer.start(at(0));
  (void)producer.process(at(1), sink);
  (void)producer.process(at(2), sink);
  producer.stop();
  EXPECT_EQ(producer.process(at(3), sink), kNever);
  producer.start(at(10));
  (void)producer.process(at(11), sink);
  ASSERT_EQ(sink.frames.size(), 3u);
  EXPECT_EQ(sink.frames[2].data[0], 1);
}

// CiA 301 §7.2.5.3: DLC 0 without counter, DLC 1 with counter 1..240.
TEST(SyncParse, CiA301_7_2_5_3_Decode) {
  SyncParse p = parse_sync(Frame::make(0x80, {}));
  ASSERT_TRUE(p.ok());
  EXPECT_FALSE(p.message.has_counter);
  p = parse_sync(Frame::make(0x80, {5}));
  ASSERT_TRUE(p.ok());
  EXPECT_TRUE(p.message.has_counter);
  EXPECT_EQ(p.message.counter, 5);
  EXPECT_TRUE(parse_sync(Frame::make(0x90, {}), 0x90).ok());
}

// CiA 301 §7.2.5.3: longer SYNCs are rejected (the EMCY 0x8240 case).
TEST(SyncParse, CiA301_7_2_5_3_RejectsMalformed) {
  EXPECT_EQ(parse_sync(Frame::make(0x80, {1, 0})).error, SyncFrameError::wrong_length);
  EXPECT_EQ(parse_sync(Frame::make8(0x80, {})).error, SyncFrameError::wrong_length);
  EXPECT_EQ(parse_sync(Frame::make(0x80, {0})).error, SyncFrameError::counter_out_of_range);
  EXPECT_EQ(parse_sync(Frame::make(0x80, {241})).error, SyncFrameError::counter_out_of_range);
  EXPECT_EQ(parse_sync(Frame::make(0x81, {})).error, SyncFrameError::wrong_cob_id);
  Frame rtr = Frame::make(0x80, {});
  rtr.flags = Frame::kFlagRtr;
  EXPECT_EQ(parse_sync(rtr).error, SyncFrameError::remote_request);
  EXPECT_EQ(to_string(SyncFrameError::wrong_length), "unexpected SYNC data length");
}

// CiA 301 §7.2.5.3: a consumer's 0x1019 decides which length it expects.
TEST(SyncParse, CiA301_1019_MatchesOverflow) {
  EXPECT_TRUE(matches_overflow({.has_counter = false, .counter = 0}, 0));
  EXPECT_FALSE(matches_overflow({.has_counter = true, .counter = 1}, 0));
  EXPECT_FALSE(matches_overflow({.has_counter = false, .counter = 0}, 10));
  EXPECT_TRUE(matches_overflow({.has_counter = true, .counter = 10}, 10));
  EXPECT_FALSE(matches_overflow({.has_counter = true, .counter = 11}, 10));
}

// CiA 301 §7.5.2.5 0x1005 (J§1.3.1, E§4.1 default 0x00000080): bit 30 = producer.
TEST(SyncCobId, CiA301_7_5_2_5_Fields) {
  const SyncCobId d = decode_sync_cob_id(0x00000080);
  EXPECT_EQ(d.id, 0x80u);
  EXPECT_FALSE(d.producer);
  EXPECT_FALSE(d.extended);
  const SyncCobId p = decode_sync_cob_id(0x40000080);
  EXPECT_TRUE(p.producer);
  EXPECT_EQ(p.id, 0x80u);
  const SyncCobId x = decode_sync_cob_id(0x20012345);
  EXPECT_TRUE(x.extended);
  EXPECT_EQ(x.id, 0x12345u);
}

}  // namespace
}  // namespace cobridge::canopen
