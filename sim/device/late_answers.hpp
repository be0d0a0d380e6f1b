// LateAnswers: holds back every Nth LSS answer of one simulated device for a
// fixed time (cobridge-sim `late_lss=N,late_lss_ms=T`). CiA 305 sets no time
// within which a slave answers; a master waits a timeout of its own, so an
// answer held longer arrives while the master is at a later step (or after it
// gave up), and a test sees whether the master matches answers to the
// requests they answer. The answer itself is unchanged.
// Thread: the simulator's loop thread (SimDevice's transmit path and
// process()); no allocation.
#pragma once

#include "can/frame.hpp"
#include "canopen/clock.hpp"

#include <array>
#include <chrono>
#include <cstdint>

namespace cobridge::sim {

class LateAnswers {
 public:
  static constexpr std::size_t kHeld = 8;  // more held at once: the extra ones leave on time

  LateAnswers() = default;
  LateAnswers(std::uint8_t every, std::chrono::milliseconds delay) noexcept : every_(every), delay_(delay) {}

  // Whether `answer` (an LSS answer about to be sent at `now`) is held; a
  // held frame leaves from release(), `delay` later.
  [[nodiscard]] bool hold(const can::Frame& answer, canopen::TimePoint now) noexcept {
    if (every_ == 0 || ++seen_ % every_ != 0 || count_ == kHeld) return false;
    held_[(first_ + count_) % kHeld] = Held{answer, now + delay_};
    ++count_;
    return true;
  }

  // Hands every held frame whose time has come to `send(frame)`, oldest
  // first; returns when the next one is due (kNever: none held).
  template <class Send>
  canopen::TimePoint release(canopen::TimePoint now, Send&& send) {
    while (count_ > 0 && held_[first_].due <= now) {
      send(held_[first_].frame);
      first_ = (first_ + 1) % kHeld;
      --count_;
      ++released_;
    }
    return count_ > 0 ? held_[first_].due : canopen::kNever;
  }

  [[nodiscard]] std::uint64_t released() const noexcept { return released_; }

  // Power off: what was held is lost with the controller's state.
  void clear() noexcept { count_ = 0; }

 private:
  struct Held {
    can::Frame frame;
    canopen::TimePoint due;
  };
  std::uint8_t every_ = 0;
  std::chrono::milliseconds delay_{};
  std::uint32_t seen_ = 0;
  std::array<Held, kHeld> held_{};
  std::size_t first_ = 0;
  std::size_t count_ = 0;
  std::uint64_t released_ = 0;
};

}  // namespace cobridge::sim
