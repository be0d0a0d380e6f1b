#include "gateway/remote/direct_answer.hpp"

#include <fcntl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <utility>

namespace cobridge::gateway {

DirectAnswer::DirectAnswer(int fd) : fd_(fd >= 0 ? ::fcntl(fd, F_DUPFD_CLOEXEC, 0) : -1) {}

DirectAnswer::~DirectAnswer() {
  if (fd_ >= 0) ::close(fd_);
}

void DirectAnswer::arm(Format format) { format_ = std::move(format); }

void DirectAnswer::shut() const noexcept {
  if (fd_ >= 0) (void)::shutdown(fd_, SHUT_WR);
}

void DirectAnswer::send(RemoteResult& result) {
  if (!format_) return;
  const Format format = std::exchange(format_, {});
  result.answer = format(result);
  result.answer_sent = 0;
  if (fd_ < 0) return;
  // One attempt: a socket that does not take the line now is the main
  // thread's to wait for (it polls for POLLOUT); EINTR is tried again.
  while (true) {
    const ssize_t n = ::send(fd_, result.answer.data(), result.answer.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n < 0 && errno == EINTR) continue;
    if (n > 0) result.answer_sent = static_cast<std::size_t>(n);
    return;
  }
}

void hand_back(RemoteCommand& command, RemoteResult result, RemoteReplies* to) {
  result.tag = command.tag;
  if (command.direct) command.direct->send(result);
  command.direct.reset();
  if (to == nullptr) return;
  // A client that has its whole answer needs nothing more from the main
  // thread until its next request, which wakes that thread anyway.
  const bool sent_whole = !result.answer.empty() && result.answer_sent == result.answer.size();
  if (sent_whole) to->push_quiet(std::move(result));
  else to->push(std::move(result));
}

}  // namespace cobridge::gateway
