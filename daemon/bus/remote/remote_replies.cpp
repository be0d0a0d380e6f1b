#include "bus/remote/remote_replies.hpp"

#include <sys/eventfd.h>
#include <unistd.h>

#include <cstdint>
#include <utility>

namespace cobridge::bus {

RemoteReplies::RemoteReplies() : fd_(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {}

RemoteReplies::~RemoteReplies() {
  if (fd_ >= 0) ::close(fd_);
}

void RemoteReplies::push(RemoteResult result) {
  {
    const std::lock_guard lock(mutex_);
    results_.push_back(std::move(result));
  }
  const std::uint64_t one = 1;
  [[maybe_unused]] const auto n = ::write(fd_, &one, sizeof one);
}

std::vector<RemoteResult> RemoteReplies::take() {
  // The counter first: a push after it makes fd() readable again, so no
  // result waits unseen.
  std::uint64_t v = 0;
  [[maybe_unused]] const auto n = ::read(fd_, &v, sizeof v);
  const std::lock_guard lock(mutex_);
  return std::exchange(results_, {});
}

}  // namespace cobridge::bus
