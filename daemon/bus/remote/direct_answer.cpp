#include "bus/remote/direct_answer.hpp"

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
  if (fd_ >= 0) (void)::shutdown(fd_, SHUT_RDWR);
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

bool answer_client(RemoteCommand& command, RemoteResult& result) {
  result.tag = command.tag;
  if (command.direct) command.direct->send(result);
  command.direct.reset();
  return !result.answer.empty() && result.answer_sent == result.answer.size();
}

bool hand_back_quietly(const RemoteCommand& command, bool sent_whole) {
  return sent_whole && !command.wake_owner;
}

void push_result(RemoteReplies& to, RemoteResult result, bool quietly) {
  // A client that has its whole answer needs nothing more from the main
  // thread until its next request, which wakes that thread anyway.
  if (quietly) to.push_quiet(std::move(result));
  else to.push(std::move(result));
}

void hand_back(RemoteCommand& command, RemoteResult result, RemoteReplies* to) {
  const bool whole = answer_client(command, result);
  if (to != nullptr) push_result(*to, std::move(result), hand_back_quietly(command, whole));
}

}  // namespace cobridge::gateway
