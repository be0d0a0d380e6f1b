// The control channel: lines from an input fd and from Unix-socket clients
// reach the handler, every line gets exactly one reply on its own channel,
// and end-of-file on stdin does not stop anything.
#include "app/control_channel.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstring>
#include <string>

namespace cobridge::sim {
namespace {

std::string echo(std::string_view line) { return "ok " + std::string(line); }

void service_once(ControlChannel& ch, int timeout_ms = 200) {
  std::vector<pollfd> fds;
  ch.append_poll_fds(fds);
  ASSERT_GE(::poll(fds.data(), fds.size(), timeout_ms), 0);
  ch.service(fds, &echo);
}

std::string read_some(int fd) {
  pollfd p{fd, POLLIN, 0};
  if (::poll(&p, 1, 1000) <= 0) return {};
  char buf[512];
  const ssize_t n = ::read(fd, buf, sizeof buf);
  return n > 0 ? std::string(buf, static_cast<std::size_t>(n)) : std::string();
}

TEST(ControlChannel, InputLinesGetOneReplyEach) {
  int in[2], out[2];
  ASSERT_EQ(::pipe(in), 0);
  ASSERT_EQ(::pipe(out), 0);
  ControlChannel ch;
  ch.watch_input(in[0], out[1]);
  const std::string cmds = "list\npower-cycle 1\npart";
  ASSERT_EQ(::write(in[1], cmds.data(), cmds.size()), static_cast<ssize_t>(cmds.size()));
  service_once(ch);
  EXPECT_EQ(read_some(out[0]), "ok list\nok power-cycle 1\n");
  ASSERT_EQ(::write(in[1], "ial\n", 4), 4);
  service_once(ch);
  EXPECT_EQ(read_some(out[0]), "ok partial\n");
  ::close(in[1]);  // EOF: watched no more, no reply, no crash
  service_once(ch);
  std::vector<pollfd> fds;
  ch.append_poll_fds(fds);
  EXPECT_TRUE(fds.empty());
  ::close(in[0]);
  ::close(out[0]);
  ::close(out[1]);
}

TEST(ControlChannel, UnixSocketClients) {
  const std::string path = "/tmp/cobridge-sim-control-test-" + std::to_string(::getpid());
  ControlChannel ch;
  ASSERT_FALSE(ch.listen(path));
  auto connect_client = [&] {
    const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    std::strncpy(a.sun_path, path.c_str(), sizeof a.sun_path - 1);
    EXPECT_EQ(::connect(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a), 0);
    return fd;
  };
  const int c1 = connect_client();
  const int c2 = connect_client();
  service_once(ch);  // accepts
  EXPECT_EQ(ch.clients(), 2u);
  ASSERT_EQ(::write(c1, "stats\n", 6), 6);
  ASSERT_EQ(::write(c2, "quit\n", 5), 5);
  service_once(ch);
  EXPECT_EQ(read_some(c1), "ok stats\n");
  EXPECT_EQ(read_some(c2), "ok quit\n");
  ::close(c1);
  service_once(ch);
  EXPECT_EQ(ch.clients(), 1u);
  ::close(c2);
}

}  // namespace
}  // namespace cobridge::sim
