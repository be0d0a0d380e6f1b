// Indices of devices the configuration does not name must be freed, must not
// collide across buses (1000 + 128 * bus + k) and must not pass the DDS
// plugin's slot count. One bounded pool for every bus, stable
// while a device is known, released and reused.
#include "outputs/device_index_pool.hpp"

#include <gtest/gtest.h>

#include <set>
#include <string>

namespace cobridge::outputs {
namespace {

TEST(DeviceIndexPool, StableWhileKnownReleasedAndReused) {
  DeviceIndexPool pool;
  const auto a = pool.acquire("0/unknown-1");
  const auto b = pool.acquire("1/unknown-1");  // another bus: another device
  ASSERT_TRUE(a && b);
  EXPECT_NE(*a, *b);
  EXPECT_EQ(pool.acquire("0/unknown-1"), a) << "the same device keeps its index";
  pool.release("0/unknown-1");
  EXPECT_EQ(pool.acquire("0/unknown-7"), a) << "a released index is reused";
}

TEST(DeviceIndexPool, BoundedAndNeverCollidingWithConfiguredDevices) {
  DeviceIndexPool pool;
  std::set<std::uint16_t> seen;
  for (int i = 0; i < DeviceIndexPool::kEnd - DeviceIndexPool::kFirst; ++i) {
    const auto idx = pool.acquire("0/unknown-" + std::to_string(i));
    ASSERT_TRUE(idx);
    EXPECT_GE(*idx, DeviceIndexPool::kFirst);
    EXPECT_LT(*idx, DeviceIndexPool::kEnd);
    EXPECT_TRUE(seen.insert(*idx).second) << "collision at " << *idx;
  }
  EXPECT_FALSE(pool.acquire("0/one-too-many")) << "used up: none rather than a colliding one";
  pool.release("0/unknown-3");
  EXPECT_TRUE(pool.acquire("0/one-too-many"));
  EXPECT_EQ(pool.in_use(), static_cast<std::size_t>(DeviceIndexPool::kEnd - DeviceIndexPool::kFirst));
}

}  // namespace
}  // namespace cobridge::outputs
