// ServiceReplies: how results of clients' commands come back from a bus's
// control thread to the thread that owns the clients' connections. Every
// result wakes the owner (its eventfd), none is lost or taken twice, and a
// result pushed by another thread is seen whole by the owner (TSan build).
#include "bus/service/service_replies.hpp"

#include <gtest/gtest.h>
#include <poll.h>

#include <cstdint>
#include <thread>
#include <vector>

using cobridge::bus::ServiceReplies;
using cobridge::bus::ServiceResult;

namespace {

bool readable(const ServiceReplies& r, int timeout_ms = 0) {
  pollfd p{r.fd(), POLLIN, 0};
  return ::poll(&p, 1, timeout_ms) == 1 && (p.revents & POLLIN) != 0;
}

ServiceResult result(std::uint64_t tag) {
  ServiceResult r;
  r.tag = tag;
  return r;
}

TEST(ServiceReplies, PushWakesTheOwnerAndTakeDrainsBoth) {
  ServiceReplies r;
  EXPECT_FALSE(readable(r));
  r.push(result(1));
  EXPECT_TRUE(readable(r));
  const auto got = r.take();
  ASSERT_EQ(got.size(), 1U);
  EXPECT_EQ(got[0].tag, 1U);
  EXPECT_FALSE(readable(r));
  EXPECT_TRUE(r.take().empty());
}

// Results pushed by a bus thread while the owner waits in poll: the owner
// wakes, and collects every result once, in the order pushed.
TEST(ServiceReplies, ResultsFromABusThreadWakeTheOwnerAndArriveInOrder) {
  ServiceReplies r;
  constexpr std::uint64_t kResults = 200;
  std::thread bus([&] {
    for (std::uint64_t tag = 1; tag <= kResults; ++tag) {
      ServiceResult res = result(tag);
      res.data = {static_cast<std::uint8_t>(tag)};
      r.push(std::move(res));
    }
  });
  std::vector<std::uint64_t> seen;
  while (seen.size() < kResults && readable(r, 2000)) {
    for (const auto& res : r.take()) {
      ASSERT_EQ(res.data.size(), 1U);
      EXPECT_EQ(res.data[0], static_cast<std::uint8_t>(res.tag));
      seen.push_back(res.tag);
    }
  }
  bus.join();
  ASSERT_EQ(seen.size(), kResults);
  for (std::uint64_t i = 0; i < kResults; ++i) EXPECT_EQ(seen[i], i + 1);
}

}  // namespace
