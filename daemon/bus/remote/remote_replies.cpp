#include "bus/remote/remote_replies.hpp"

#include <sys/eventfd.h>
#include <unistd.h>

#include <utility>

namespace cobridge::gateway {

RemoteReplies::RemoteReplies() : fd_(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {}

RemoteReplies::~RemoteReplies() {
  if (fd_ >= 0) ::close(fd_);
}

void RemoteReplies::push(RemoteResult result) {
  {
    const std::lock_guard lock(mutex_);
    results_.push_back(std::move(result));
    wake_wanted_ = false;
  }
  const std::uint64_t one = 1;
  [[maybe_unused]] const auto n = ::write(fd_, &one, sizeof one);
}

void RemoteReplies::push_quiet(RemoteResult result) {
  bool wake = false;
  {
    const std::lock_guard lock(mutex_);
    results_.push_back(std::move(result));
    wake = std::exchange(wake_wanted_, false);
  }
  if (!wake) return;
  const std::uint64_t one = 1;
  [[maybe_unused]] const auto n = ::write(fd_, &one, sizeof one);
}

std::vector<RemoteResult> RemoteReplies::take() {
  std::uint64_t v = 0;
  [[maybe_unused]] const auto n = ::read(fd_, &v, sizeof v);
  const std::lock_guard lock(mutex_);
  return std::exchange(results_, {});
}

std::vector<RemoteResult> RemoteReplies::take_quiet() {
  const std::lock_guard lock(mutex_);
  return std::exchange(results_, {});
}

bool RemoteReplies::want_wake() {
  const std::lock_guard lock(mutex_);
  if (!results_.empty()) return false;
  wake_wanted_ = true;
  return true;
}

}  // namespace cobridge::gateway
