// StatusBoard: the bus-wide part of a bus's status that is not any one
// device's: the problems an operator must see, and the timings of the last
// commissioning and configuration steps. Both are bounded, so that a bus
// that keeps failing cannot grow its status without end.
//
// A problem stays while it is true: its owner takes it away (a device's
// own problems when it is operational, a clash's when it is resolved). The
// same text twice is one problem. Each change returns whether the board
// changed, so the controller republishes only then.
// Control thread only.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "bus/device_status.hpp"

namespace cobridge::bus {

class StatusBoard {
 public:
  static constexpr std::size_t kMaxSteps = 64;     // step timings kept (the oldest go)
  static constexpr std::size_t kMaxProblems = 32;  // problems kept (the oldest go)

  struct Problem {
    std::string text;
    std::string device;           // the configured device it is about (empty: the bus)
    std::uint8_t clash_node = 0;  // a clash at this node-ID (0: none)
  };

  // False when the same text is already there.
  bool add_problem(std::string text, std::string device = {}, std::uint8_t clash_node = 0);
  // The problems of device `name`; of the clash at `node`. True when any went.
  bool clear_device(const std::string& name);
  bool clear_clash(std::uint8_t node);
  void add_step(StepTiming t);

  [[nodiscard]] const std::vector<Problem>& problems() const noexcept { return problems_; }
  [[nodiscard]] const std::vector<StepTiming>& steps() const noexcept { return steps_; }

 private:
  std::vector<Problem> problems_;
  std::vector<StepTiming> steps_;
};

}  // namespace cobridge::bus
