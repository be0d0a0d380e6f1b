// Commission retries: see commission_retries.hpp.
#include "bus/discovery/commission_retries.hpp"

#include "bus/discovery/bus_picture.hpp"

#include <algorithm>

namespace cobridge::bus::discovery {

canopen::Duration CommissionRetries::wait_after(std::uint32_t failures) noexcept {
  canopen::Duration w = kFirstRetry;
  for (std::uint32_t i = 1; i < failures && w < kMaxRetry; ++i) w *= 2;
  return std::min(w, kMaxRetry);
}

RetryEntry* CommissionRetries::entry(const canopen::LssAddress& a) {
  auto it = std::find_if(entries_.begin(), entries_.end(),
                         [&](const RetryEntry& e) { return same_device(e.identity, a); });
  return it == entries_.end() ? nullptr : &*it;
}

const RetryEntry* CommissionRetries::find(const canopen::LssAddress& a) const {
  return const_cast<CommissionRetries*>(this)->entry(a);
}

const RetryEntry& CommissionRetries::failed(const canopen::LssAddress& a, const std::string& device,
                                            std::uint8_t node, const std::string& cause, canopen::TimePoint now) {
  RetryEntry* e = entry(a);
  if (e == nullptr) {
    entries_.push_back(RetryEntry{a, device, node, 0, {}, canopen::kNever});
    e = &entries_.back();
  }
  e->node = node;
  if (!device.empty()) e->device = device;
  ++e->failures;
  e->cause = cause;
  e->next_try = now + wait_after(e->failures);
  return *e;
}

void CommissionRetries::succeeded(const canopen::LssAddress& a) {
  std::erase_if(entries_, [&](const RetryEntry& e) { return same_device(e.identity, a); });
}

std::vector<RetryEntry> CommissionRetries::take_due(canopen::TimePoint now) {
  std::vector<RetryEntry> due;
  for (auto& e : entries_) {
    if (now < e.next_try) continue;
    e.next_try = now + wait_after(e.failures + 1);
    due.push_back(e);
  }
  return due;
}

canopen::TimePoint CommissionRetries::next_due() const noexcept {
  canopen::TimePoint t = canopen::kNever;
  for (const auto& e : entries_) t = std::min(t, e.next_try);
  return t;
}

}  // namespace cobridge::bus::discovery
