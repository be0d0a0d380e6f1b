// cobridge-sim-latency's pairing of answers with requests (CiA 305 §8.3 LSS,
// CiA 301 §7.2.4.3 SDO): what it measures and what it refuses to measure.
#include "answer_pairing.hpp"

#include <gtest/gtest.h>

#include <array>

namespace cobridge::sim::tools {
namespace {

void frame(AnswerPairing& p, std::uint32_t id, std::uint8_t cs, std::int64_t t_ns) {
  const std::array<std::uint8_t, 8> d{cs, 0, 0, 0, 0, 0, 0, 0};
  p.on_frame(id, d.data(), 8, t_ns);
}

TEST(AnswerPairing, EveryFastscanAnswerIsMeasuredFromItsRequest_CiA305_8_3_5) {
  AnswerPairing p;
  frame(p, 0x7E5, 0x51, 1'000);
  frame(p, 0x7E4, 0x4F, 1'300);  // two slaves match the step
  frame(p, 0x7E4, 0x4F, 1'500);
  frame(p, 0x7E5, 0x51, 10'000);  // nobody matches: a silent step
  frame(p, 0x7E5, 0x04, 20'000);  // switch state global: never answered
  p.finish();
  EXPECT_EQ(p.lss().requests, 3U);
  EXPECT_EQ(p.lss().answers, 2U);
  EXPECT_EQ(p.lss().unanswered, 2U);
  EXPECT_EQ(p.lss().repeats, 1U);  // the second slave's frame
  EXPECT_EQ(p.lss().latency_ns, (std::vector<std::int64_t>{300, 500}));
}

TEST(AnswerPairing, LateLssAnswerIsCountedNotMeasuredAgainstALaterRequest_CiA305_8_3_2) {
  AnswerPairing p;
  frame(p, 0x7E5, 0x11, 0);       // configure node-ID
  frame(p, 0x7E5, 0x17, 5'000);   // store, before the configure's answer
  frame(p, 0x7E4, 0x11, 5'100);   // the configure's answer, late
  frame(p, 0x7E4, 0x17, 5'200);
  EXPECT_EQ(p.lss().mismatched, 1U);
  EXPECT_EQ(p.lss().latency_ns, (std::vector<std::int64_t>{200}));
}

TEST(AnswerPairing, SwitchSelectiveIsAnsweredAfterItsLastFrame_CiA305_8_3_2) {
  AnswerPairing p;
  for (std::uint8_t cs = 0x40; cs <= 0x43; ++cs) frame(p, 0x7E5, cs, cs * 100);
  frame(p, 0x7E4, 0x44, 0x43 * 100 + 250);
  EXPECT_EQ(p.lss().latency_ns, (std::vector<std::int64_t>{250}));
}

TEST(AnswerPairing, SdoAnswerClosesItsNodesRequest_CiA301_7_2_4_3) {
  AnswerPairing p;
  frame(p, 0x614, 0x2B, 0);
  frame(p, 0x615, 0x2B, 100);
  frame(p, 0x595, 0x60, 400);
  frame(p, 0x594, 0x60, 900);
  frame(p, 0x594, 0x60, 950);  // a second answer: nothing pending
  frame(p, 0x616, 0x40, 1'000);
  p.finish();
  EXPECT_EQ(p.sdo().requests, 3U);
  EXPECT_EQ(p.sdo().answers, 2U);
  EXPECT_EQ(p.sdo().mismatched, 1U);
  EXPECT_EQ(p.sdo().unanswered, 1U);
  EXPECT_EQ(p.sdo().downloads, 2U);  // 0x2B: expedited download of 2 bytes
  EXPECT_EQ(p.sdo().latency_ns, (std::vector<std::int64_t>{300, 900}));
}

TEST(AnswerPairing, EchoPingsArePairedWithTheirAnswers) {
  AnswerPairing p;
  frame(p, 0x7F0, 0, 0);
  frame(p, 0x7F1, 0, 120);
  frame(p, 0x7F0, 1, 10'000);
  p.finish();
  EXPECT_EQ(p.echo().requests, 2U);
  EXPECT_EQ(p.echo().unanswered, 1U);
  EXPECT_EQ(p.echo().latency_ns, (std::vector<std::int64_t>{120}));
}

TEST(AnswerPairing, NearestRankPercentiles) {
  std::vector<std::int64_t> v;
  for (std::int64_t i = 100; i >= 1; --i) v.push_back(i);
  const LatencySummary s = summarize(v);
  EXPECT_EQ(s.count, 100U);
  EXPECT_EQ(s.p50_ns, 50);
  EXPECT_EQ(s.p99_ns, 99);
  EXPECT_EQ(s.max_ns, 100);
  EXPECT_EQ(summarize({}).count, 0U);
  EXPECT_EQ(summarize({7}).p99_ns, 7);
}

}  // namespace
}  // namespace cobridge::sim::tools
