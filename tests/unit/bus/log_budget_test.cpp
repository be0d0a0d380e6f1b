// LogBudget (an EMCY storm can write thousands of log lines in seconds):
// at most N lines per window, the rest counted and reported once the window
// has passed, so that logged + suppressed always equals what happened.
#include "bus/log_budget.hpp"

#include <gtest/gtest.h>

namespace cobridge::bus {
namespace {

using namespace std::chrono_literals;
using canopen::TimePoint;

TEST(LogBudget, StormIsCutToTheBudgetAndCountedInFull) {
  LogBudget budget(5, 10s);
  TimePoint t{1000s};
  unsigned logged = 0;
  for (int i = 0; i < 4600; ++i) logged += budget.allow(t + i * 650us) ? 1u : 0u;  // 4 600 in ~3 s
  EXPECT_EQ(logged, 5u);
  EXPECT_EQ(budget.take_suppressed(t + 3s), 0u) << "not before the window ends";
  EXPECT_EQ(budget.report_due(), t + 10s);
  EXPECT_EQ(budget.take_suppressed(t + 10s), 4595u);
  EXPECT_EQ(budget.take_suppressed(t + 11s), 0u) << "reported once";
  EXPECT_EQ(budget.report_due(), canopen::kNever);
}

TEST(LogBudget, NewWindowLogsAgainAfterTheSummary) {
  LogBudget budget(2, 10s);
  TimePoint t{1000s};
  EXPECT_TRUE(budget.allow(t));
  EXPECT_TRUE(budget.allow(t + 1s));
  EXPECT_FALSE(budget.allow(t + 2s));
  // The window is over but its summary is still owed: counted into it.
  EXPECT_FALSE(budget.allow(t + 10s));
  EXPECT_EQ(budget.take_suppressed(t + 10s), 2u);
  EXPECT_TRUE(budget.allow(t + 10s));
  EXPECT_TRUE(budget.allow(t + 12s));
  EXPECT_FALSE(budget.allow(t + 13s));
}

TEST(LogBudget, QuietSourceIsNeverCut) {
  LogBudget budget(5, 10s);
  TimePoint t{1000s};
  for (int i = 0; i < 100; ++i) EXPECT_TRUE(budget.allow(t + i * 3s));
  EXPECT_EQ(budget.report_due(), canopen::kNever);
}

}  // namespace
}  // namespace cobridge::bus
