// StatusBoard: the bus's problems and step timings in its status
// (docs/operations.md "Reading the status"): one line per problem while it
// holds, both lists bounded.
#include "bus/status_board.hpp"

#include <gtest/gtest.h>

#include <string>

namespace cobridge::bus {
namespace {

TEST(StatusBoard, TheSameProblemTwiceIsOneLine) {
  StatusBoard b;
  EXPECT_TRUE(b.add_problem("device a: SDO timeout", "a"));
  EXPECT_FALSE(b.add_problem("device a: SDO timeout", "a"));
  EXPECT_TRUE(b.add_problem("device a: abort 0x06090011", "a"));
  EXPECT_EQ(b.problems().size(), 2u);
}

TEST(StatusBoard, ADevicesProblemsGoWhenItIsOperationalOthersStay) {
  StatusBoard b;
  (void)b.add_problem("device a: SDO timeout", "a");
  (void)b.add_problem("device b: no answer", "b");
  (void)b.add_problem("two devices answer at node 5", "", 5);
  (void)b.add_problem("state file held");
  EXPECT_TRUE(b.clear_device("a"));
  EXPECT_FALSE(b.clear_device("a"));
  ASSERT_EQ(b.problems().size(), 3u);
  EXPECT_EQ(b.problems()[0].device, "b");
  EXPECT_FALSE(b.clear_clash(6));
  EXPECT_TRUE(b.clear_clash(5));
  ASSERT_EQ(b.problems().size(), 2u);
  EXPECT_EQ(b.problems()[1].text, "state file held") << "a bus problem is no clash's and no device's";
}

TEST(StatusBoard, BothListsKeepTheNewestWithinTheirBound) {
  StatusBoard b;
  for (std::size_t i = 0; i < StatusBoard::kMaxProblems + 5; ++i) (void)b.add_problem("p" + std::to_string(i));
  ASSERT_EQ(b.problems().size(), StatusBoard::kMaxProblems);
  EXPECT_EQ(b.problems().front().text, "p5");
  EXPECT_EQ(b.problems().back().text, "p" + std::to_string(StatusBoard::kMaxProblems + 4));
  for (std::size_t i = 0; i < StatusBoard::kMaxSteps + 3; ++i) {
    StepTiming t;
    t.step = "step" + std::to_string(i);
    b.add_step(std::move(t));
  }
  ASSERT_EQ(b.steps().size(), StatusBoard::kMaxSteps);
  EXPECT_EQ(b.steps().front().step, "step3");
}

}  // namespace
}  // namespace cobridge::bus
