// The failed-login log lines: the client and the user
// name tried, never the password; a user name cannot forge a log line.
#include "web/login_log.hpp"

#include <gtest/gtest.h>

#include <string>

using namespace std::chrono_literals;
using cobridge::web::failed_login_line;
using cobridge::web::LoginThrottle;
using cobridge::web::printable_user;
using cobridge::web::refused_login_line;
using cobridge::web::seconds_up;

namespace {

TEST(LoginLog, LinesNameTheClientTheUserAndTheWindow) {
  LoginThrottle::Verdict v;
  v.failures = 3;
  v.retry_after = 4s;
  EXPECT_EQ(failed_login_line("192.0.2.7", "alice", v),
            "failed login from 192.0.2.7 as \"alice\" (3 in a row); credentials not checked for 4 s");
  v.retry_after = 1500ms;
  v.failed_unlogged = 2;
  v.refused_unlogged = 5;
  EXPECT_EQ(refused_login_line("2001:db8::5", "", v),
            "login from 2001:db8::5 without a user name refused (429): 3 failed in a row, 2 s left; "
            "since the last line: 2 more failed, 5 refused");
  EXPECT_EQ(failed_login_line("", "bob", LoginThrottle::Verdict{1, 1s}),
            "failed login from an unknown address as \"bob\" (1 in a row); credentials not checked for 1 s");
}

TEST(LoginLog, AUserNameCannotForgeALine) {
  EXPECT_EQ(printable_user("alice"), "alice");
  EXPECT_EQ(printable_user("a\nwarning web: fake"), "a\\x0awarning web: fake");
  EXPECT_EQ(printable_user("q\"uote\\"), "q\\x22uote\\x5c");
  EXPECT_EQ(printable_user("\xc3\xa9\x1b[31m"), "\\xc3\\xa9\\x1b[31m");
  EXPECT_EQ(printable_user(std::string(100, 'a')), std::string(64, 'a') + "...");
}

// Retry-After's delay-seconds (RFC 9110 §10.2.3): whole seconds, rounded up, at least 1.
TEST(LoginLog, Rfc9110Sec10_2_3_RetryAfterIsWholeSecondsRoundedUp) {
  EXPECT_EQ(seconds_up(0ms), 1);
  EXPECT_EQ(seconds_up(1ms), 1);
  EXPECT_EQ(seconds_up(1000ms), 1);
  EXPECT_EQ(seconds_up(1001ms), 2);
  EXPECT_EQ(seconds_up(8s), 8);
}

}  // namespace
