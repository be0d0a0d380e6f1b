// LoginThrottle: the web service's memory of failed basic-authentication
// logins, per client (an IPv4 address, an IPv6 /64: see web/peer_address.hpp).
//
// After a client's n-th failed login in a row its credentials are not
// checked again for a window of first_delay * 2^(n-1), at most max_delay;
// a request in that window is answered 429 with Retry-After (RFC 6585 §4)
// at once, without a password hash computation: nothing sleeps, so one
// client's backoff never holds up another's request on libmicrohttpd's one
// thread, and a guesser gets at most one hash of CPU per window. A
// successful login, or `forget` without a failure, starts the client over.
//
// Each failure, and the refusals in a window, are for the log; one line per
// client per log_interval at most (`log`), the ones not logged counted into
// the next line, so a flood of guesses cannot flood the journal.
//
// Bounded: at most max_clients clients are remembered; a new one past that
// first drops the forgotten ones, then the one whose last failure is oldest.
//
// Time is passed in (steady clock), so tests need no sleeps.
// Thread: any; one mutex (libmicrohttpd's thread, and tests calling handle()).
#pragma once

#include <chrono>
#include <cstddef>
#include <mutex>
#include <string>
#include <unordered_map>

namespace cobridge::web {

class LoginThrottle {
 public:
  using Clock = std::chrono::steady_clock;

  struct Limits {
    Clock::duration first_delay = std::chrono::seconds(1);  // the window after a first failure
    Clock::duration max_delay = std::chrono::seconds(8);    // doubling stops here
    Clock::duration forget = std::chrono::minutes(10);      // no failure for this long: start over
    Clock::duration log_interval = std::chrono::seconds(1); // one log line per client per interval
    std::size_t max_clients = 1024;
  };

  // What one failed or refused attempt means for the client.
  struct Verdict {
    unsigned failures = 0;          // failed logins in a row (refusals not counted)
    Clock::duration retry_after{};  // until the window ends
    bool log = false;               // log a line for this attempt now
    unsigned failed_unlogged = 0;   // when `log`: failures since the last line, this one excluded
    unsigned refused_unlogged = 0;  // when `log`: refusals since the last line, this one excluded
  };

  LoginThrottle() = default;
  explicit LoginThrottle(Limits limits) : limits_(limits) {}

  // How long `client` must still wait before its credentials are checked; zero: now.
  [[nodiscard]] Clock::duration wait(const std::string& client, Clock::time_point now) const;
  // `client` sent wrong credentials: its window opens (or widens).
  Verdict failed(const std::string& client, Clock::time_point now);
  // `client` asked inside its window (answered 429): counted for the log only.
  Verdict refused(const std::string& client, Clock::time_point now);
  // `client` logged in: forgotten.
  void succeeded(const std::string& client);

  [[nodiscard]] std::size_t clients() const;
  [[nodiscard]] const Limits& limits() const noexcept { return limits_; }

 private:
  struct Entry {
    unsigned failures = 0;
    Clock::time_point last_failure{};
    Clock::time_point retry_at{};
    Clock::time_point last_log{};
    bool logged = false;  // last_log is set
    unsigned failed_unlogged = 0;
    unsigned refused_unlogged = 0;
  };

  [[nodiscard]] Clock::duration delay_after(unsigned failures) const;
  // Whether `e` gets a log line now; fills the counts of what it did not log.
  void decide_log(Entry& e, Clock::time_point now, Verdict& v, bool failure) const;
  // Room for one more client: drops forgotten clients, then the stalest.
  void make_room(Clock::time_point now);

  Limits limits_;
  mutable std::mutex mutex_;
  std::unordered_map<std::string, Entry> clients_;
};

}  // namespace cobridge::web
