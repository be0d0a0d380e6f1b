// The log lines of failed and refused web logins (logger "web", warning):
// the client's address and the user name it tried, never the password. How
// often a client gets a line is LoginThrottle's verdict (`log`); what it
// did since its last line is counted into the next.
// Thread: any; pure functions.
#pragma once

#include "web/login_throttle.hpp"

#include <string>
#include <string_view>

namespace cobridge::web {

// "failed login from 192.0.2.7 as \"alice\" (3 in a row); credentials not
// checked for 4 s[; since the last line: 2 more failed, 5 refused]"
[[nodiscard]] std::string failed_login_line(std::string_view client, std::string_view user,
                                            const LoginThrottle::Verdict& v);

// "login from 192.0.2.7 as \"alice\" refused (429): 3 failed in a row, 2 s
// left[; since the last line: ...]"
[[nodiscard]] std::string refused_login_line(std::string_view client, std::string_view user,
                                             const LoginThrottle::Verdict& v);

// `user` as it may go into a log line: printable ASCII kept, every other
// byte (control bytes: a forged line; '"', '\\') as \xNN, at most 64 bytes
// of it; "" becomes "(none)". A user name is whatever a client sent.
[[nodiscard]] std::string printable_user(std::string_view user);

// A wait in whole seconds, rounded up, at least 1: Retry-After's
// delay-seconds (RFC 9110 §10.2.3) and the log's figure.
[[nodiscard]] long long seconds_up(LoginThrottle::Clock::duration d) noexcept;

}  // namespace cobridge::web
