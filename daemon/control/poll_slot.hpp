// PollSlot: one descriptor a component hands to the owner's poll(), and
// whether poll() saw it ready. The control socket and the CiA 309-3 gateway
// touch (accept, recv, read the reply eventfd) only what is ready: on a
// single-CPU host every needless system call sits in the path of a client's
// answer (an SDO read through the daemon adds <= 2 ms).
//
// "Unknown" counts as ready: a component whose owner did not report the
// poll result (tests driving process() directly, the first turn, a
// descriptor added after the poll) tries everything, as it did before.
//
// Threads: the thread that owns the component (add before poll, note after,
// take in process).
#pragma once

#include <poll.h>

#include <cstddef>
#include <limits>
#include <vector>

namespace cobridge::control {

class PollSlot {
 public:
  // Appends `fd` to the poll set and remembers where.
  void add(std::vector<pollfd>& fds, int fd, short events) {
    index_ = fds.size();
    fds.push_back({fd, events, 0});
  }
  // Not in this poll set (nothing to wait for): not ready after note().
  void skip() noexcept { index_ = kNone; }
  // After poll(): ready when poll reported anything for the descriptor.
  void note(const std::vector<pollfd>& fds) noexcept {
    ready_ = index_ < fds.size() && fds[index_].revents != 0;
    index_ = kNone;
  }
  // Something else made it worth a try (an answer to send, a new client).
  void mark() noexcept { ready_ = true; }
  // Known not ready until the next poll says otherwise (a descriptor just
  // added whose owner reports every poll: no try before it).
  void clear() noexcept { ready_ = false; }
  // Whether to try it now; back to "unknown" afterwards.
  [[nodiscard]] bool take() noexcept {
    const bool r = ready_;
    ready_ = true;
    return r;
  }

 private:
  static constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
  std::size_t index_ = kNone;
  bool ready_ = true;
};

}  // namespace cobridge::control
