// PollSlot (bus/service/poll_slot.hpp): a component touches only what poll()
// reported ready; without a poll result it tries everything.
#include "control/poll_slot.hpp"

#include <gtest/gtest.h>

namespace {

using cobridge::control::PollSlot;

TEST(PollSlot, UnknownCountsAsReady) {
  PollSlot s;
  EXPECT_TRUE(s.take());
  EXPECT_TRUE(s.take());  // still unknown: no poll result was noted
}

TEST(PollSlot, ReadyOnlyWhenPollReportedSomething) {
  PollSlot a;
  PollSlot b;
  std::vector<pollfd> fds;
  a.add(fds, 5, POLLIN);
  b.add(fds, 6, POLLOUT);
  ASSERT_EQ(fds.size(), 2U);
  EXPECT_EQ(fds[1].fd, 6);
  EXPECT_EQ(fds[1].events, POLLOUT);
  fds[1].revents = POLLHUP;  // a hang-up is worth a look too
  a.note(fds);
  b.note(fds);
  EXPECT_FALSE(a.take());
  EXPECT_TRUE(b.take());
  EXPECT_TRUE(a.take());  // taken: unknown again until the next poll
}

TEST(PollSlot, SkippedIsNotReadyUntilMarked) {
  PollSlot s;
  std::vector<pollfd> fds{{7, POLLIN, POLLIN}};
  s.skip();
  s.note(fds);  // index 0 belongs to someone else
  EXPECT_FALSE(s.take());
  s.skip();
  s.note(fds);
  s.mark();  // an answer arrived for it
  EXPECT_TRUE(s.take());
}

}  // namespace
