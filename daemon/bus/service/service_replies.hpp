// ServiceReplies: the way results of ServiceRequests come back from a bus's
// control thread to the thread that owns the clients' connections (the
// daemon's main thread: the control socket and the CiA 309-3 gateway). The
// bus thread only push()es a result; the owner polls fd(), take()s it and
// writes the client's answer itself, so a client's socket is only ever
// touched by its owning thread.
// Shared (std::shared_ptr) so that a reply to a client that left, or to a
// server already closed, lands in a live object.
//
// Thread contract: push() from any thread (a mutex and an eventfd write;
// the bus control threads, never the hot path); fd() and take() from the
// owner.
#pragma once

#include "bus/service/service_request.hpp"

#include <mutex>
#include <vector>

namespace cobridge::bus {

class ServiceReplies {
 public:
  ServiceReplies();
  ~ServiceReplies();
  ServiceReplies(const ServiceReplies&) = delete;
  ServiceReplies& operator=(const ServiceReplies&) = delete;

  // Queues a result and makes fd() readable.
  void push(ServiceResult result);
  // Readable while pushed results wait; take() empties it and the queue.
  [[nodiscard]] int fd() const noexcept { return fd_; }
  [[nodiscard]] std::vector<ServiceResult> take();

 private:
  int fd_ = -1;
  std::mutex mutex_;
  std::vector<ServiceResult> results_;
};

}  // namespace cobridge::bus
