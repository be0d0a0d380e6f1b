// cobridge-sim-latency: how fast the slaves on a CAN interface answer, seen
// from outside them. It reads every frame of the interface on its own
// CAN_RAW socket with the kernel's receive time (SO_TIMESTAMPNS), pairs each
// LSS answer (0x7E4) and SDO answer (0x580+n) with the request it answers
// (0x7E5, 0x600+n; answer_pairing.hpp says how), and on SIGTERM/SIGINT
// prints, per service, the counts and the p50/p99/max of answer time minus
// request time, plus the frames the kernel dropped before this socket read
// them (SO_RXQ_OVFL): a figure from a reader that missed frames is not one.
//
// On vcan both times are stamped as each frame enters the interface, so the
// latency is the answering process's own: from the request on the bus to
// its answer on the bus.
//
//   cobridge-sim-latency [--iface vcan0]      prints "ready", then reads
//
// Output (one line each, at the end):
//   lss requests=N answers=N unanswered=N mismatched=N downloads=0 repeats=N p50_us=X p99_us=X max_us=X
//   sdo requests=N answers=N unanswered=N mismatched=N downloads=N repeats=0 p50_us=X p99_us=X max_us=X
//   echo requests=N ... (cobridge-bus-echo's pings and answers: the same run's floor)
// (downloads: SDO writes, CiA 301 initiate download requests)
//   frames=N drops=N
// Thread: one (main).
#include "answer_pairing.hpp"

#include "stop_signals.hpp"

#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

namespace {

using cobridge::sim::tools::AnswerPairing;
using cobridge::sim::tools::ServiceCounts;

constexpr unsigned kBatch = 64;

struct Reader {
  AnswerPairing pairing;
  std::uint64_t frames = 0;
  std::uint32_t drops = 0;  // the socket's cumulative SO_RXQ_OVFL count
};

int open_socket(const std::string& iface) {
  const int fd = ::socket(AF_CAN, SOCK_RAW, CAN_RAW);
  if (fd < 0) return -1;
  const int on = 1;
  // Room for a burst of several thousand frames while this process waits for the CPU.
  const int rcvbuf = 4 << 20;
  (void)::setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &rcvbuf, sizeof rcvbuf);
  if (::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) != 0 ||
      ::setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on) != 0)
    return -1;
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(::if_nametoindex(iface.c_str()));
  if (addr.can_ifindex == 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) return -1;
  return fd;
}

void take_control(Reader& r, msghdr& h, const can_frame& f) {
  std::int64_t t_ns = -1;
  for (cmsghdr* c = CMSG_FIRSTHDR(&h); c != nullptr; c = CMSG_NXTHDR(&h, c)) {
    if (c->cmsg_level != SOL_SOCKET) continue;
    if (c->cmsg_type == SO_TIMESTAMPNS) {
      timespec ts{};
      std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
      t_ns = static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
    } else if (c->cmsg_type == SO_RXQ_OVFL) {
      std::memcpy(&r.drops, CMSG_DATA(c), sizeof r.drops);
    }
  }
  ++r.frames;
  if (t_ns < 0 || (f.can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG | CAN_ERR_FLAG)) != 0) return;
  r.pairing.on_frame(f.can_id & CAN_SFF_MASK, f.data, f.can_dlc, t_ns);
}

// Reads what is queued, in batches; returns false on a socket error.
bool drain(int fd, Reader& r) {
  std::array<can_frame, kBatch> frames{};
  std::array<iovec, kBatch> iov{};
  std::array<mmsghdr, kBatch> msgs{};
  std::array<std::array<char, CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(std::uint32_t))>, kBatch> ctl{};
  for (;;) {
    for (unsigned i = 0; i < kBatch; ++i) {
      iov[i] = iovec{&frames[i], sizeof(can_frame)};
      msgs[i] = mmsghdr{};
      msgs[i].msg_hdr.msg_iov = &iov[i];
      msgs[i].msg_hdr.msg_iovlen = 1;
      msgs[i].msg_hdr.msg_control = ctl[i].data();
      msgs[i].msg_hdr.msg_controllen = ctl[i].size();
    }
    const int n = ::recvmmsg(fd, msgs.data(), kBatch, MSG_DONTWAIT, nullptr);
    if (n < 0) return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR;
    for (unsigned i = 0; i < static_cast<unsigned>(n); ++i) take_control(r, msgs[i].msg_hdr, frames[i]);
    if (n < static_cast<int>(kBatch)) return true;
  }
}

void print(const char* name, const ServiceCounts& c) {
  const auto s = cobridge::sim::tools::summarize(c.latency_ns);
  std::printf("%s requests=%llu answers=%llu unanswered=%llu mismatched=%llu downloads=%llu repeats=%llu "
              "p50_us=%.1f p99_us=%.1f max_us=%.1f\n",
              name, static_cast<unsigned long long>(c.requests), static_cast<unsigned long long>(c.answers),
              static_cast<unsigned long long>(c.unanswered), static_cast<unsigned long long>(c.mismatched),
              static_cast<unsigned long long>(c.downloads), static_cast<unsigned long long>(c.repeats),
              static_cast<double>(s.p50_ns) / 1e3, static_cast<double>(s.p99_ns) / 1e3,
              static_cast<double>(s.max_ns) / 1e3);
}

}  // namespace

int main(int argc, char** argv) {
  std::string iface = "vcan0";
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--iface") == 0 && i + 1 < argc) {
      iface = argv[++i];
    } else {
      std::fprintf(stderr, "usage: cobridge-sim-latency [--iface IFACE]\n");
      return 2;
    }
  }
  const int sfd = cobridge::sim::tools::stop_signal_fd();
  const int fd = open_socket(iface);
  if (fd < 0 || sfd < 0) {
    std::fprintf(stderr, "cobridge-sim-latency: %s: %s\n", iface.c_str(), std::strerror(errno));
    return 1;
  }
  std::puts("ready");
  std::fflush(stdout);
  Reader r;
  std::array<pollfd, 2> fds{pollfd{fd, POLLIN, 0}, pollfd{sfd, POLLIN, 0}};
  for (;;) {
    if (::poll(fds.data(), fds.size(), -1) < 0 && errno != EINTR) break;
    if (!drain(fd, r)) break;
    if ((fds[1].revents & POLLIN) != 0) break;
  }
  (void)drain(fd, r);
  r.pairing.finish();
  print("lss", r.pairing.lss());
  print("sdo", r.pairing.sdo());
  print("echo", r.pairing.echo());
  std::printf("frames=%llu drops=%u\n", static_cast<unsigned long long>(r.frames), r.drops);
  return 0;
}
