// RemoteReplies: the way results of RemoteCommands come back to the thread
// that submitted them. A bus's control thread push()es; the owner (the main
// thread's control socket or ASCII gateway) polls fd() and take()s.
// Shared (std::shared_ptr) so that a reply to a client that left, or to a
// server already closed, lands in a live object.
//
// Thread contract: push() from any thread (a mutex and an eventfd write; the
// control threads only, never the hot path); fd()/take() from the owner.
#pragma once

#include "gateway/remote/remote_command.hpp"

#include <mutex>
#include <vector>

namespace cobridge::gateway {

class RemoteReplies {
 public:
  RemoteReplies();
  ~RemoteReplies();
  RemoteReplies(const RemoteReplies&) = delete;
  RemoteReplies& operator=(const RemoteReplies&) = delete;

  void push(RemoteResult result);
  // Readable while results wait; take() empties it.
  [[nodiscard]] int fd() const noexcept { return fd_; }
  [[nodiscard]] std::vector<RemoteResult> take();

 private:
  int fd_ = -1;
  std::mutex mutex_;
  std::vector<RemoteResult> results_;
};

}  // namespace cobridge::gateway
