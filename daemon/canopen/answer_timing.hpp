// AnswerTiming: how long to wait for LSS answers on one bus, learnt from the
// answers seen there rather than fixed.
//
// A search step (Fastscan bit, identify) learns something from silence, so
// it must wait long enough for the slowest slave to answer, and no longer.
// CiA 305 fixes no LSS response time and none of the three manuals states
// one (J§1.5, E§6, F§7.4 give only the services), so the wait is measured:
// every answer records how long after its request it came; an unanswered
// step then waits 4 x the slowest answer seen + 1 ms (the slowest of the
// recent answers: a slower answer raises it at once, faster ones lower it by
// 1/16 of the difference each, so a single outlier is forgotten within a few
// dozen answers) (slack for the
// scheduler of both ends), never below the configured floor and never
// above the configured ceiling (the bus's `lss_timeout_ms`, also used
// before anything was measured). An answered step goes on once the slowest
// answer time seen has passed after its first answer, so that the answers
// of several slaves to the same step all fall into it.
//
// Thread: owned by the LssMaster's thread; no clock reads.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>

#include "canopen/clock.hpp"

namespace cobridge::canopen {

class AnswerTiming {
 public:
  // floor == ceiling: fixed waits, nothing learnt (the classic behaviour).
  AnswerTiming(Duration floor, Duration ceiling) noexcept
      : floor_(std::min(floor, ceiling)), ceiling_(ceiling) {}

  // An answer arrived `latency` after the request it answers.
  void record(Duration latency) noexcept;

  // How long a step without answer waits before silence counts.
  [[nodiscard]] Duration no_answer_wait() const noexcept;
  // After a step's first answer, how long to wait for the other slaves' answers.
  [[nodiscard]] Duration settle() const noexcept;

  [[nodiscard]] bool learning() const noexcept { return floor_ < ceiling_; }
  [[nodiscard]] Duration slowest() const noexcept { return slowest_; }
  [[nodiscard]] std::uint32_t answers() const noexcept { return answers_; }
  [[nodiscard]] Duration ceiling() const noexcept { return ceiling_; }

 private:
  Duration floor_;
  Duration ceiling_;
  Duration slowest_{};
  std::uint32_t answers_ = 0;
};

}  // namespace cobridge::canopen
