// RemoteReplies: the way results of RemoteCommands come back to the thread
// that submitted them. A bus's control thread push()es; the owner (the main
// thread's control socket or ASCII gateway) polls fd() and take()s.
// Shared (std::shared_ptr) so that a reply to a client that left, or to a
// server already closed, lands in a live object.
//
// Thread contract: push()/push_quiet() from any thread (a mutex, and an
// eventfd write when it wakes the owner; the control threads only, never the
// hot path); fd(), take(), take_quiet() and want_wake() from the owner.
//
// push_quiet() is for a result whose client already has its whole answer
// (DirectAnswer): waking the owner then would put its turn between the
// client and the client's next request on UML's one CPU. The
// owner collects such results on its next turn (any wake-up, at most its
// poll tick later), or asks for a wake-up with want_wake() when a client's
// next request is there before its result.
#pragma once

#include "bus/remote/remote_command.hpp"

#include <mutex>
#include <vector>

namespace cobridge::gateway {

class RemoteReplies {
 public:
  RemoteReplies();
  ~RemoteReplies();
  RemoteReplies(const RemoteReplies&) = delete;
  RemoteReplies& operator=(const RemoteReplies&) = delete;

  // Queues a result and makes fd() readable.
  void push(RemoteResult result);
  // Queues a result; makes fd() readable only if the owner asked (want_wake).
  void push_quiet(RemoteResult result);
  // Readable while pushed results wait; take() empties it and the queue.
  [[nodiscard]] int fd() const noexcept { return fd_; }
  [[nodiscard]] std::vector<RemoteResult> take();
  // The queued results, without a system call (fd() is left as it is).
  [[nodiscard]] std::vector<RemoteResult> take_quiet();
  // True: nothing is queued, and the next push of any kind makes fd()
  // readable. False: results are queued now (take them).
  [[nodiscard]] bool want_wake();

 private:
  int fd_ = -1;
  std::mutex mutex_;
  std::vector<RemoteResult> results_;
  bool wake_wanted_ = false;
};

}  // namespace cobridge::gateway
