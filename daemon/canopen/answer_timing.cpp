#include "canopen/answer_timing.hpp"

namespace cobridge::canopen {

namespace {
constexpr Duration kSlack = std::chrono::milliseconds(1);
constexpr Duration kMinSettle = std::chrono::microseconds(500);
}  // namespace

void AnswerTiming::record(Duration latency) noexcept {
  if (latency < Duration::zero() || latency > ceiling_) return;  // not an answer to this request
  // The slowest answer, forgotten slowly: one late answer (the slave's or
  // the gateway's scheduler) must not slow every later step of the bus, so a
  // faster answer pulls the estimate 1/16 of the way down; a slower one
  // raises it at once.
  if (latency >= slowest_) slowest_ = latency;
  else slowest_ -= (slowest_ - latency) / 16;
  ++answers_;
}

Duration AnswerTiming::no_answer_wait() const noexcept {
  if (!learning() || answers_ == 0) return ceiling_;
  return std::clamp(4 * slowest_ + kSlack, floor_, ceiling_);
}

Duration AnswerTiming::settle() const noexcept {
  if (!learning()) return ceiling_;
  return std::clamp(slowest_, kMinSettle, no_answer_wait());
}

}  // namespace cobridge::canopen
