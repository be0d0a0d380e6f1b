#include "bus/service/service_replies.hpp"

#include <sys/eventfd.h>
#include <unistd.h>

#include <cstdint>
#include <utility>

namespace cobridge::bus {

ServiceReplies::ServiceReplies() : fd_(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {}

ServiceReplies::~ServiceReplies() {
  if (fd_ >= 0) ::close(fd_);
}

void ServiceReplies::push(ServiceResult result) {
  {
    const std::lock_guard lock(mutex_);
    results_.push_back(std::move(result));
  }
  const std::uint64_t one = 1;
  [[maybe_unused]] const auto n = ::write(fd_, &one, sizeof one);
}

std::vector<ServiceResult> ServiceReplies::take() {
  // The counter first: a push after it makes fd() readable again, so no
  // result waits unseen.
  std::uint64_t v = 0;
  [[maybe_unused]] const auto n = ::read(fd_, &v, sizeof v);
  const std::lock_guard lock(mutex_);
  return std::exchange(results_, {});
}

}  // namespace cobridge::bus
