// Commission retries: the devices whose
// commissioning failed (no answer to LSS configure node-ID, a slave error,
// no answer to switch selective) and when each is tried again.
//
// A device that was found, or that the configuration names, is never given
// up: every failure doubles its wait, 1 s, 2 s, 4 s ... capped at 30 s, and
// the search for it runs again when the wait is over. Each failure is
// counted and its cause kept, so that status says which device keeps
// refusing and why. Once the device is commissioned its entry goes.
//
// Thread: the bus's control thread (Commissioning's); no clock reads.
#pragma once

#include "canopen/clock.hpp"
#include "canopen/lss.hpp"

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace cobridge::bus::discovery {

inline constexpr canopen::Duration kFirstRetry = std::chrono::seconds(1);
inline constexpr canopen::Duration kMaxRetry = std::chrono::seconds(30);

struct RetryEntry {
  canopen::LssAddress identity;
  std::string device;     // configured name; empty = unknown device
  std::uint8_t node = 0xFF;  // where it is (FFh: non-configured; else a move's old node-ID)
  std::uint32_t failures = 0;
  std::string cause;      // the last failure's
  canopen::TimePoint next_try = canopen::kNever;
};

class CommissionRetries {
 public:
  // `a` failed once more: its entry, with the next try scheduled.
  const RetryEntry& failed(const canopen::LssAddress& a, const std::string& device, std::uint8_t node,
                           const std::string& cause, canopen::TimePoint now);
  // Commissioned: no more tries.
  void succeeded(const canopen::LssAddress& a);
  // The entries whose wait is over, once per due time. Their waits are
  // pushed back as if this try failed too (a try that does not reach the
  // device, e.g. because it is not there, still backs off); a real failure
  // reschedules from its own time.
  std::vector<RetryEntry> take_due(canopen::TimePoint now);
  [[nodiscard]] canopen::TimePoint next_due() const noexcept;
  [[nodiscard]] const RetryEntry* find(const canopen::LssAddress& a) const;
  [[nodiscard]] const std::vector<RetryEntry>& entries() const noexcept { return entries_; }

  // 1 s, 2 s, 4 s ... after the 1st, 2nd, 3rd ... failure, at most kMaxRetry.
  [[nodiscard]] static canopen::Duration wait_after(std::uint32_t failures) noexcept;

 private:
  RetryEntry* entry(const canopen::LssAddress& a);
  std::vector<RetryEntry> entries_;
};

}  // namespace cobridge::bus::discovery
