// HeldCommands: a ServiceTarget with one bus (net 1, "line1" on vcan0) whose
// control thread is the test: submitted commands wait until finish() ends
// the oldest one the way ServiceExecutor::reply() does (the result, with the
// command's tag, pushed to its reply queue). For the control socket and
// CiA 309-3 gateway tests.
//
// Threads: submit() from the server under test, finish()/held() from the
// test; both under the mutex.
#pragma once

#include "bus/service/service_replies.hpp"
#include "bus/service/service_target.hpp"

#include <cstddef>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string_view>
#include <utility>
#include <vector>

namespace cobridge::control::testing {

class HeldCommands final : public bus::ServiceTarget {
 public:
  [[nodiscard]] std::vector<bus::ServiceBus> buses() const override { return {{"line1", "vcan0", 1}}; }
  [[nodiscard]] Error submit(std::string_view, bus::ServiceRequest command, std::shared_ptr<bus::ServiceReplies> to) override {
    const std::lock_guard lock(mutex_);
    held_.emplace_back(std::move(command), std::move(to));
    return {};
  }
  [[nodiscard]] std::optional<config::ServiceAccess> access() const override {
    const std::lock_guard lock(mutex_);
    return access_;
  }
  // What access() answers from now on (nothing = no configuration: writes refused).
  void set_access(std::optional<config::ServiceAccess> access) {
    const std::lock_guard lock(mutex_);
    access_ = std::move(access);
  }

  [[nodiscard]] std::size_t held() {
    const std::lock_guard lock(mutex_);
    return held_.size();
  }
  // False when no command waits.
  bool finish(bus::ServiceResult result) {
    std::pair<bus::ServiceRequest, std::shared_ptr<bus::ServiceReplies>> oldest;
    {
      const std::lock_guard lock(mutex_);
      if (held_.empty()) return false;
      oldest = std::move(held_.front());
      held_.pop_front();
    }
    result.tag = oldest.first.tag;
    if (oldest.second) oldest.second->push(std::move(result));
    return true;
  }
  // The oldest command still waiting, as the bus would run it (a copy).
  [[nodiscard]] std::optional<bus::ServiceRequest> oldest() const {
    const std::lock_guard lock(mutex_);
    if (held_.empty()) return std::nullopt;
    return held_.front().first;
  }

 private:
  mutable std::mutex mutex_;
  std::optional<config::ServiceAccess> access_;
  std::deque<std::pair<bus::ServiceRequest, std::shared_ptr<bus::ServiceReplies>>> held_;
};

}  // namespace cobridge::control::testing
