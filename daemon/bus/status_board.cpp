// StatusBoard: see status_board.hpp.
#include "bus/status_board.hpp"

#include <algorithm>
#include <utility>

namespace cobridge::bus {

bool StatusBoard::add_problem(std::string text, std::string device, std::uint8_t clash_node) {
  const bool known = std::any_of(problems_.begin(), problems_.end(), [&](const Problem& p) { return p.text == text; });
  if (known) return false;
  problems_.push_back(Problem{std::move(text), std::move(device), clash_node});
  if (problems_.size() > kMaxProblems) problems_.erase(problems_.begin());
  return true;
}

bool StatusBoard::clear_device(const std::string& name) {
  return std::erase_if(problems_, [&](const Problem& p) { return p.device == name; }) != 0;
}

bool StatusBoard::clear_clash(std::uint8_t node) {
  return std::erase_if(problems_, [&](const Problem& p) { return p.clash_node == node; }) != 0;
}

void StatusBoard::add_step(StepTiming t) {
  steps_.push_back(std::move(t));
  if (steps_.size() > kMaxSteps) steps_.erase(steps_.begin());
}

}  // namespace cobridge::bus
