// HistoryBuffer (store and forward, Sparkplug 3.0 5.x): bounded, oldest
// dropped first and counted, kept in order, no allocation after reset().
#include "history_buffer.hpp"

#include <gtest/gtest.h>

#include <array>

namespace cobridge::mqtt {
namespace {

std::array<Reading, 1> pos(std::int64_t v) { return {Reading{DeviceMetric::kPosition, Scalar{v, 0.0}}}; }

TEST(HistoryBuffer, OldestDroppedFirstWhenFull) {
  HistoryBuffer h;
  h.reset(4, 0);
  std::size_t dropped = 0;
  for (int i = 1; i <= 6; ++i) dropped += h.push(static_cast<std::uint64_t>(i), pos(i * 10));
  EXPECT_EQ(dropped, 2u);
  ASSERT_EQ(h.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(h.at(i).ts_ms, i + 3) << i;  // 3, 4, 5, 6: in order, the first two gone
    EXPECT_EQ(h.at(i).values[0].i, static_cast<std::int64_t>((i + 3) * 10));
  }
}

TEST(HistoryBuffer, EntriesOlderThanTheWindowDropped) {
  HistoryBuffer h;
  h.reset(100, 1000);
  EXPECT_EQ(h.push(1000, pos(1)), 0u);
  EXPECT_EQ(h.push(1500, pos(2)), 0u);
  EXPECT_EQ(h.push(2200, pos(3)), 1u);  // 1000 is more than 1 s behind 2200
  ASSERT_EQ(h.size(), 2u);
  EXPECT_EQ(h.at(0).ts_ms, 1500u);
}

TEST(HistoryBuffer, OffStoresNothing) {
  HistoryBuffer h;
  h.reset(0, 0);
  EXPECT_EQ(h.push(1, pos(1)), 0u);
  EXPECT_EQ(h.size(), 0u);
}

}  // namespace
}  // namespace cobridge::mqtt
