// Failed logins slowed per client: an exponential
// window in which the client is answered 429 Too Many Requests with
// Retry-After (RFC 6585 §4), log lines rate-limited per client, a bounded
// table. Time is passed in: no test sleeps.
#include "web/login_throttle.hpp"

#include <gtest/gtest.h>

#include <string>

using namespace std::chrono_literals;
using cobridge::web::LoginThrottle;

namespace {

const LoginThrottle::Clock::time_point t0 = LoginThrottle::Clock::time_point{} + 1h;

TEST(LoginThrottle, EachFailureDoublesTheWindowUpToTheCap) {
  LoginThrottle t;  // 1 s, doubling, 8 s at most
  const std::string c = "192.0.2.7";
  EXPECT_EQ(t.wait(c, t0), 0s) << "a client that never failed may try";
  auto now = t0;
  for (const auto expected : {1s, 2s, 4s, 8s, 8s, 8s}) {
    const auto v = t.failed(c, now);
    EXPECT_EQ(v.retry_after, expected);
    EXPECT_EQ(t.wait(c, now), expected);
    EXPECT_EQ(t.wait(c, now + expected - 1ms), 1ms);
    EXPECT_EQ(t.wait(c, now + expected), 0s);
    now += expected;
  }
  EXPECT_EQ(t.failed(c, now).failures, 7U);
}

TEST(LoginThrottle, OneClientsWindowIsNotAnothers) {
  LoginThrottle t;
  (void)t.failed("192.0.2.7", t0);
  EXPECT_GT(t.wait("192.0.2.7", t0), 0s);
  EXPECT_EQ(t.wait("192.0.2.8", t0), 0s);
  EXPECT_EQ(t.wait("2001:db8::/64", t0), 0s);
}

TEST(LoginThrottle, ASuccessOrALongQuietStartsOver) {
  LoginThrottle t;
  const std::string c = "192.0.2.7";
  (void)t.failed(c, t0);
  (void)t.failed(c, t0 + 1s);
  t.succeeded(c);
  EXPECT_EQ(t.wait(c, t0 + 1s), 0s);
  EXPECT_EQ(t.clients(), 0U);
  EXPECT_EQ(t.failed(c, t0 + 2s).retry_after, 1s) << "back to the first window";

  (void)t.failed(c, t0 + 3s);  // the 2nd in a row: 2 s
  EXPECT_EQ(t.failed(c, t0 + 3s + 10min - 1ms).failures, 3U);
  EXPECT_EQ(t.failed(c, t0 + 3s + 20min).failures, 1U) << "10 minutes without a failure: forgotten";
}

TEST(LoginThrottle, AtMostOneLogLinePerClientPerSecondWithTheRestCounted) {
  LoginThrottle t;
  const std::string c = "192.0.2.7";
  const auto first = t.failed(c, t0);
  EXPECT_TRUE(first.log);
  EXPECT_EQ(first.failed_unlogged, 0U);
  // Refused inside the window, within the second: counted, not logged.
  for (int i = 0; i < 5; ++i) EXPECT_FALSE(t.refused(c, t0 + 100ms * (i + 1)).log);
  const auto r = t.refused(c, t0 + 600ms);
  EXPECT_FALSE(r.log);
  EXPECT_EQ(r.retry_after, 400ms);
  // The next failure, a second later: logged, with the 6 refusals before it.
  const auto second = t.failed(c, t0 + 1s);
  EXPECT_TRUE(second.log);
  EXPECT_EQ(second.refused_unlogged, 6U);
  EXPECT_EQ(second.failed_unlogged, 0U);
  // Another client is logged at once, whatever the first one did.
  EXPECT_TRUE(t.failed("192.0.2.8", t0 + 1s).log);
}

// With a window shorter than the log interval, failures themselves are
// rate-limited in the log and counted into the next line.
TEST(LoginThrottle, FailuresFasterThanTheLogIntervalAreCounted) {
  LoginThrottle::Limits l;
  l.first_delay = 10ms;
  l.max_delay = 10ms;
  LoginThrottle t(l);
  const std::string c = "192.0.2.7";
  EXPECT_TRUE(t.failed(c, t0).log);
  for (int i = 1; i < 10; ++i) EXPECT_FALSE(t.failed(c, t0 + 10ms * i).log) << i;
  const auto v = t.failed(c, t0 + 1s);
  EXPECT_TRUE(v.log);
  EXPECT_EQ(v.failed_unlogged, 9U);
  EXPECT_EQ(v.failures, 11U);
}

TEST(LoginThrottle, TheTableIsBounded) {
  LoginThrottle::Limits l;
  l.max_clients = 4;
  LoginThrottle t(l);
  for (int i = 0; i < 100; ++i) {
    (void)t.failed("198.51.100." + std::to_string(i), t0 + 1ms * i);
    EXPECT_LE(t.clients(), 4U);
  }
  // The stalest went first: the last four are remembered.
  for (int i = 96; i < 100; ++i) EXPECT_GT(t.wait("198.51.100." + std::to_string(i), t0 + 100ms), 0s) << i;
  EXPECT_EQ(t.wait("198.51.100.0", t0 + 100ms), 0s);

  // Forgotten clients make room before a remembered one is dropped.
  LoginThrottle u(l);
  (void)u.failed("a", t0);
  (void)u.failed("b", t0);
  (void)u.failed("c", t0 + 30min);  // a and b are forgotten by now
  (void)u.failed("d", t0 + 30min);
  (void)u.failed("e", t0 + 30min);
  EXPECT_EQ(u.clients(), 3U);
  EXPECT_GT(u.wait("c", t0 + 30min), 0s);
}

TEST(LoginThrottle, ARefusalOfAnUnknownClientIsHarmless) {
  LoginThrottle t;
  const auto v = t.refused("192.0.2.7", t0);
  EXPECT_EQ(v.failures, 0U);
  EXPECT_EQ(t.clients(), 0U);
}

}  // namespace
