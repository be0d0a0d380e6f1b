// cobridge-bus-echo: the smallest possible CAN responder, and its pinger: the
// floor that any answering process meets on the same interface, machine and
// load, so the simulator's answer latency (cobridge-sim-latency) can be
// judged against it in the same run.
//
//   cobridge-bus-echo --answer [--rt-priority N] [--iface vcan0]
//       answers every frame 0x7F0 at once with 0x7F1 and the same data
//   cobridge-bus-echo --ping MS [--iface vcan0]
//       sends 0x7F0 every MS milliseconds, a counter in its data
// Both print "ready" once their socket is bound and end on SIGTERM/SIGINT.
// cobridge-sim-latency pairs 0x7F0 -> 0x7F1 as its `echo` line.
// 0x7F0/0x7F1 are not used by CiA 301/305 services nor by the simulated devices.
// Thread: one (main).
#include "stop_signals.hpp"

#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

namespace {

constexpr canid_t kPing = 0x7F0;
constexpr canid_t kAnswer = 0x7F1;

int open_socket(const std::string& iface, bool answer) {
  const int fd = ::socket(AF_CAN, SOCK_RAW, CAN_RAW);
  if (fd < 0) return -1;
  // The answerer reads only the pings; the pinger reads nothing.
  can_filter f{kPing, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG};
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, &f, answer ? sizeof f : 0) != 0) return -1;
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(::if_nametoindex(iface.c_str()));
  if (addr.can_ifindex == 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) return -1;
  return fd;
}

void answer_all(int fd) {
  can_frame f{};
  while (::recv(fd, &f, sizeof f, MSG_DONTWAIT) == static_cast<ssize_t>(sizeof f)) {
    f.can_id = kAnswer;
    (void)::send(fd, &f, sizeof f, 0);
  }
}

void ping(int fd, std::uint32_t n) {
  can_frame f{};
  f.can_id = kPing;
  f.can_dlc = 8;
  std::memcpy(f.data, &n, sizeof n);
  (void)::send(fd, &f, sizeof f, 0);
}

int run(int fd, int sfd, int ping_ms) {
  std::puts("ready");
  std::fflush(stdout);
  std::array<pollfd, 2> fds{pollfd{fd, POLLIN, 0}, pollfd{sfd, POLLIN, 0}};
  std::uint32_t n = 0;
  for (;;) {
    const int r = ::poll(fds.data(), fds.size(), ping_ms > 0 ? ping_ms : -1);
    if (r < 0 && errno != EINTR) return 1;
    if ((fds[1].revents & POLLIN) != 0) return 0;
    if (ping_ms > 0 && r == 0) ping(fd, n++);
    if (ping_ms == 0 && (fds[0].revents & POLLIN) != 0) answer_all(fd);
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string iface = "vcan0";
  int ping_ms = -1;
  int priority = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--answer") ping_ms = 0;
    else if (a == "--ping" && i + 1 < argc) ping_ms = std::atoi(argv[++i]);
    else if (a == "--rt-priority" && i + 1 < argc) priority = std::atoi(argv[++i]);
    else if (a == "--iface" && i + 1 < argc) iface = argv[++i];
    else ping_ms = -2;
  }
  if (ping_ms < 0) {
    std::fprintf(stderr, "usage: cobridge-bus-echo --answer [--rt-priority N] | --ping MS  [--iface IFACE]\n");
    return 2;
  }
  const sched_param p{priority};
  if (priority > 0 && ::sched_setscheduler(0, SCHED_FIFO, &p) != 0) {
    std::fprintf(stderr, "cobridge-bus-echo: --rt-priority %d: %s\n", priority, std::strerror(errno));
    return 1;
  }
  const int sfd = cobridge::sim::tools::stop_signal_fd();
  const int fd = open_socket(iface, ping_ms == 0);
  if (fd < 0 || sfd < 0) {
    std::fprintf(stderr, "cobridge-bus-echo: %s: %s\n", iface.c_str(), std::strerror(errno));
    return 1;
  }
  return run(fd, sfd, ping_ms);
}
