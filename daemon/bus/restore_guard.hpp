// RestoreGuard: drift restores that cannot fight another writer for ever.
//
// With on_config_drift = "restore" the gateway writes a configured object
// back when a client changed it (bus/config_drift.hpp). A second master or a
// PLC that keeps writing its own value would then meet a restore each time:
// an endless round of pre-operational, rewrite, store and start, wearing the
// device's non-volatile memory (18 restores in 40 s were measured). So each
// object's restores are counted: each waits longer than the one before
// (RestoreLimits::backoff), and a drift after `max_restores` restores within
// `window` marks the object contested. A contested object is written and
// stored no more until an operator acknowledges it (acknowledge()); its
// counts then start over.
//
// Thread: owned by the bus's control thread; no clock reads, `now` is
// passed in.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <vector>

#include "canopen/clock.hpp"

namespace cobridge::bus {

// One configured object, as a number: index << 8 | sub.
[[nodiscard]] constexpr std::uint32_t object_number(std::uint16_t index, std::uint8_t sub) noexcept {
  return (std::uint32_t{index} << 8U) | sub;
}

struct RestoreLimits {
  static constexpr unsigned kMaxRestores = 3;
  std::chrono::seconds window{600};
  // The wait between a drift and the restore it starts, for the 1st, 2nd
  // and 3rd restore within the window: the first is at once (a one-off
  // change is put right before anyone relies on it), later ones leave the
  // other writer room to show it keeps writing.
  std::array<canopen::Duration, kMaxRestores> backoff{std::chrono::seconds(0), std::chrono::seconds(5),
                                                     std::chrono::seconds(20)};
};

class RestoreGuard {
 public:
  enum class Verdict : std::uint8_t {
    restore,    // restore at Decision::not_before
    contested,  // this drift made the object contested: write nothing
    held,       // the object was contested already: write nothing
  };
  struct Decision {
    Verdict verdict = Verdict::restore;
    canopen::TimePoint not_before{};
    unsigned restores = 0;  // restores of the object within the window, this one included
  };

  explicit RestoreGuard(RestoreLimits limits = {}) : limits_(limits) {}

  // A client's write of (index, sub) differs from the configuration and the
  // device's policy is to restore it. Counts the restore it grants.
  [[nodiscard]] Decision on_drift(std::uint16_t index, std::uint8_t sub, canopen::TimePoint now);
  [[nodiscard]] bool contested(std::uint16_t index, std::uint8_t sub) const;
  [[nodiscard]] bool any_contested() const;
  // The operator's word: contested objects may be written again and every
  // count starts over. Returns how many objects were contested.
  std::size_t acknowledge();

 private:
  struct Object {
    std::uint32_t key = 0;  // index << 8 | sub
    std::vector<canopen::TimePoint> restores;  // within the window, oldest first; at most kMaxRestores
    bool contested = false;
  };
  Object& object(std::uint32_t key);
  [[nodiscard]] const Object* find(std::uint32_t key) const;

  RestoreLimits limits_;
  std::vector<Object> objects_;  // the few objects a plan sets: a vector, searched
};

}  // namespace cobridge::bus
