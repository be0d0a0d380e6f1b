// CommissionRetries ("nobody left behind"): a failed device is
// tried again after 1 s, 2 s, 4 s ... at most 30 s, never dropped, until it
// is commissioned.
#include "bus/discovery/commission_retries.hpp"

#include <gtest/gtest.h>

namespace cobridge::bus::discovery {
namespace {

using namespace std::chrono_literals;

const canopen::LssAddress kDev{0x182, 0x0BB8, 0x00010005, 2001};

TEST(CommissionRetries, WaitDoublesFromOneSecondAndStopsAtThirty) {
  EXPECT_EQ(CommissionRetries::wait_after(1), 1s);
  EXPECT_EQ(CommissionRetries::wait_after(2), 2s);
  EXPECT_EQ(CommissionRetries::wait_after(3), 4s);
  EXPECT_EQ(CommissionRetries::wait_after(5), 16s);
  EXPECT_EQ(CommissionRetries::wait_after(6), 30s);
  EXPECT_EQ(CommissionRetries::wait_after(1000), 30s);
}

TEST(CommissionRetries, AFailureIsDueAfterItsWaitOnceAndKeepsItsCause) {
  CommissionRetries r;
  const canopen::TimePoint t0{};
  const RetryEntry& e = r.failed(kDev, "mt-a", 0xFF, "LSS configure node-ID 20 failed", t0);
  EXPECT_EQ(e.failures, 1u);
  EXPECT_EQ(r.next_due(), t0 + 1s);
  EXPECT_TRUE(r.take_due(t0 + 999ms).empty());
  const auto due = r.take_due(t0 + 1s);
  ASSERT_EQ(due.size(), 1u);
  EXPECT_EQ(due[0].device, "mt-a");
  EXPECT_EQ(due[0].cause, "LSS configure node-ID 20 failed");
  // Taken: not due again at once; a try that never reached it backs off too.
  EXPECT_TRUE(r.take_due(t0 + 1s).empty());
  EXPECT_EQ(r.next_due(), t0 + 3s);
}

TEST(CommissionRetries, EveryFailureCountsAndOnlySuccessEndsTheTries) {
  CommissionRetries r;
  canopen::TimePoint t{};
  for (int i = 0; i < 10; ++i) t = r.failed(kDev, "mt-a", 0xFF, "no answer", t).next_try;
  ASSERT_NE(r.find(kDev), nullptr);
  EXPECT_EQ(r.find(kDev)->failures, 10u);
  EXPECT_EQ(r.next_due() - t, 0s);
  r.succeeded(kDev);
  EXPECT_EQ(r.find(kDev), nullptr);
  EXPECT_EQ(r.next_due(), canopen::kNever);
}

}  // namespace
}  // namespace cobridge::bus::discovery
