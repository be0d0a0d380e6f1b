// RemoteReplies: how results of clients' commands come back to the main
// thread (issue 15: an SDO read through the daemon adds <= 1 ms; a result
// whose answer the bus thread already sent whole must not wake the main
// thread on the client's way, yet never be lost or wait for a tick when the
// main thread asked for it).
#include "bus/remote/remote_replies.hpp"

#include <gtest/gtest.h>
#include <poll.h>

using cobridge::gateway::RemoteReplies;
using cobridge::gateway::RemoteResult;

namespace {

bool readable(const RemoteReplies& r) {
  pollfd p{r.fd(), POLLIN, 0};
  return ::poll(&p, 1, 0) == 1 && (p.revents & POLLIN) != 0;
}

RemoteResult result(std::uint64_t tag) {
  RemoteResult r;
  r.tag = tag;
  return r;
}

TEST(RemoteReplies, PushWakesTheOwnerAndTakeDrainsBoth) {
  RemoteReplies r;
  EXPECT_FALSE(readable(r));
  r.push(result(1));
  EXPECT_TRUE(readable(r));
  const auto got = r.take();
  ASSERT_EQ(got.size(), 1U);
  EXPECT_EQ(got[0].tag, 1U);
  EXPECT_FALSE(readable(r));
}

TEST(RemoteReplies, QuietPushWaitsUnseenUntilTaken) {
  RemoteReplies r;
  r.push_quiet(result(7));
  EXPECT_FALSE(readable(r));  // no wake-up of the main thread
  const auto got = r.take_quiet();
  ASSERT_EQ(got.size(), 1U);
  EXPECT_EQ(got[0].tag, 7U);
  EXPECT_TRUE(r.take_quiet().empty());
}

// The owner saw the client's next request before its result: it asks, and
// the quiet push that follows wakes it (once: the request after does not).
TEST(RemoteReplies, AQuietPushWakesTheOwnerThatAskedOnce) {
  RemoteReplies r;
  EXPECT_TRUE(r.want_wake());
  r.push_quiet(result(3));
  EXPECT_TRUE(readable(r));
  EXPECT_EQ(r.take().size(), 1U);
  r.push_quiet(result(4));
  EXPECT_FALSE(readable(r));
  EXPECT_EQ(r.take_quiet().size(), 1U);
}

// A result already queued when the owner asks: it is told to take it now
// (no wake-up would come for it).
TEST(RemoteReplies, AskingWhileResultsWaitSaysTakeThem) {
  RemoteReplies r;
  r.push_quiet(result(5));
  EXPECT_FALSE(r.want_wake());
  EXPECT_EQ(r.take_quiet().size(), 1U);
  EXPECT_TRUE(r.want_wake());
  r.push(result(6));  // a loud push answers the request too
  EXPECT_TRUE(readable(r));
  EXPECT_EQ(r.take().size(), 1U);
  r.push_quiet(result(8));
  EXPECT_FALSE(readable(r));
}

}  // namespace
