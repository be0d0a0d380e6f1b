#include "web/login_throttle.hpp"

#include <algorithm>

namespace cobridge::web {

LoginThrottle::Clock::duration LoginThrottle::delay_after(unsigned failures) const {
  Clock::duration d = limits_.first_delay;
  for (unsigned i = 1; i < failures && d < limits_.max_delay; ++i) d *= 2;  // no shift past the cap: no overflow
  return std::min(d, limits_.max_delay);
}

LoginThrottle::Clock::duration LoginThrottle::wait(const std::string& client, Clock::time_point now) const {
  const std::lock_guard lock(mutex_);
  const auto it = clients_.find(client);
  if (it == clients_.end() || now >= it->second.retry_at) return Clock::duration::zero();
  return it->second.retry_at - now;
}

void LoginThrottle::decide_log(Entry& e, Clock::time_point now, Verdict& v, bool failure) const {
  v.log = !e.logged || now - e.last_log >= limits_.log_interval;
  if (!v.log) {
    ++(failure ? e.failed_unlogged : e.refused_unlogged);
    return;
  }
  v.failed_unlogged = e.failed_unlogged;
  v.refused_unlogged = e.refused_unlogged;
  e.failed_unlogged = 0;
  e.refused_unlogged = 0;
  e.last_log = now;
  e.logged = true;
}

LoginThrottle::Verdict LoginThrottle::failed(const std::string& client, Clock::time_point now) {
  const std::lock_guard lock(mutex_);
  if (clients_.find(client) == clients_.end() && clients_.size() >= limits_.max_clients) make_room(now);
  Entry& e = clients_[client];
  if (e.failures > 0 && now - e.last_failure >= limits_.forget) e = Entry{};
  ++e.failures;
  e.last_failure = now;
  e.retry_at = now + delay_after(e.failures);
  Verdict v;
  v.failures = e.failures;
  v.retry_after = e.retry_at - now;
  decide_log(e, now, v, true);
  return v;
}

LoginThrottle::Verdict LoginThrottle::refused(const std::string& client, Clock::time_point now) {
  const std::lock_guard lock(mutex_);
  Verdict v;
  const auto it = clients_.find(client);
  if (it == clients_.end()) return v;  // forgotten meanwhile (made room for another)
  Entry& e = it->second;
  v.failures = e.failures;
  v.retry_after = now < e.retry_at ? e.retry_at - now : Clock::duration::zero();
  decide_log(e, now, v, false);
  return v;
}

void LoginThrottle::succeeded(const std::string& client) {
  const std::lock_guard lock(mutex_);
  clients_.erase(client);
}

std::size_t LoginThrottle::clients() const {
  const std::lock_guard lock(mutex_);
  return clients_.size();
}

void LoginThrottle::make_room(Clock::time_point now) {
  std::erase_if(clients_, [&](const auto& kv) {
    return now - kv.second.last_failure >= limits_.forget && now >= kv.second.retry_at;
  });
  if (clients_.empty() || clients_.size() < limits_.max_clients) return;
  const auto stalest = std::min_element(clients_.begin(), clients_.end(), [](const auto& a, const auto& b) {
    return a.second.last_failure < b.second.last_failure;
  });
  clients_.erase(stalest);
}

}  // namespace cobridge::web
