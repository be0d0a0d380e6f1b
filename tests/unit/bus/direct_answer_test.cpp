// DirectAnswer (bus/remote/direct_answer.hpp): the bus thread's write of
// a client's answer line (issue 15: an SDO read through the daemon adds
// <= 1 ms, so the main thread is taken off the answer's path). Real Unix
// stream sockets. The rules checked: the line goes out whole when the
// socket takes it; what the socket does not take is left, byte-exact, to
// the main thread (no loss, no reordering); only an armed command is
// answered, once; a connection shut by the main thread gets nothing more.
#include "bus/remote/direct_answer.hpp"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <string>

namespace {

using cobridge::gateway::DirectAnswer;
using cobridge::gateway::RemoteResult;

struct Pair {
  Pair() { EXPECT_EQ(::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds.data()), 0); }
  ~Pair() {
    for (const int fd : fds)
      if (fd >= 0) ::close(fd);
  }
  // Everything readable now on the client's side; "<eof>" appended at its end.
  std::string drain() const {
    std::string got;
    std::array<char, 65536> buf{};
    while (true) {
      const ssize_t n = ::recv(fds[1], buf.data(), buf.size(), MSG_DONTWAIT);
      if (n == 0) return got + "<eof>";
      if (n < 0) return got;
      got.append(buf.data(), static_cast<std::size_t>(n));
    }
  }
  std::array<int, 2> fds{-1, -1};  // [0]: the daemon's, [1]: the client's
};

DirectAnswer::Format line_of(std::string text) {
  return [text](const RemoteResult& r) { return text + " tag " + std::to_string(r.tag) + "\n"; };
}

TEST(DirectAnswer, SendsTheWholeLineWhenTheSocketTakesIt) {
  Pair p;
  DirectAnswer d(p.fds[0]);
  d.arm(line_of("ok"));
  RemoteResult r;
  r.tag = 7;
  d.send(r);
  EXPECT_EQ(r.answer, "ok tag 7\n");
  EXPECT_EQ(r.answer_sent, r.answer.size());
  EXPECT_EQ(p.drain(), "ok tag 7\n");
}

TEST(DirectAnswer, AnswersOnlyAnArmedCommandAndOnlyOnce) {
  Pair p;
  DirectAnswer d(p.fds[0]);
  RemoteResult unarmed;
  d.send(unarmed);
  EXPECT_TRUE(unarmed.answer.empty());  // the main thread's path, as before
  d.arm(line_of("first"));
  RemoteResult a;
  d.send(a);
  RemoteResult again;
  d.send(again);
  EXPECT_TRUE(again.answer.empty());
  EXPECT_EQ(p.drain(), "first tag 0\n");
}

// The client does not read: the socket takes part or none of the line, and
// the rest (answer minus answer_sent) is what the main thread must send.
TEST(DirectAnswer, WhatAFullSocketDoesNotTakeIsLeftToTheMainThread) {
  Pair p;
  const std::string filler(4096, 'f');
  std::size_t filled = 0;
  while (true) {
    const ssize_t n = ::send(p.fds[0], filler.data(), filler.size(), MSG_DONTWAIT);
    if (n <= 0) break;
    filled += static_cast<std::size_t>(n);
  }
  ASSERT_EQ(errno, EAGAIN);
  DirectAnswer d(p.fds[0]);
  const std::string big(200000, 'x');
  d.arm(line_of(big));
  RemoteResult r;
  d.send(r);
  ASSERT_EQ(r.answer.size(), big.size() + std::string(" tag 0\n").size());
  EXPECT_LT(r.answer_sent, r.answer.size());
  const std::string got = p.drain();
  ASSERT_EQ(got.size(), filled + r.answer_sent);
  EXPECT_EQ(got.substr(filled), r.answer.substr(0, r.answer_sent));
}

// The main thread closed the connection while the command ran: the peer
// sees the end at once although the bus thread still holds its duplicate,
// and the late answer is not sent.
TEST(DirectAnswer, AShutConnectionEndsAtOnceAndGetsNoAnswer) {
  Pair p;
  DirectAnswer d(p.fds[0]);
  d.arm(line_of("late"));
  d.shut();
  ::close(p.fds[0]);
  p.fds[0] = -1;
  RemoteResult r;
  d.send(r);
  EXPECT_EQ(r.answer_sent, 0U);
  EXPECT_EQ(p.drain(), "<eof>");
}

}  // namespace
