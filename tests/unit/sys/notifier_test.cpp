// Notifier against a notify socket the test holds (sd_notify(3) protocol:
// one datagram per call, newline-separated assignments).
#include "sys/notifier.hpp"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstddef>
#include <cstdlib>
#include <string>

#include "unit/support/datagram_receiver.hpp"

using cobridge::sys::Notifier;

namespace {

class NotifySocket {
 public:
  NotifySocket() { ::setenv("NOTIFY_SOCKET", socket_.path().c_str(), 1); }
  ~NotifySocket() {
    ::unsetenv("NOTIFY_SOCKET");
    ::unsetenv("WATCHDOG_USEC");
    ::unsetenv("WATCHDOG_PID");
  }
  NotifySocket(const NotifySocket&) = delete;
  NotifySocket& operator=(const NotifySocket&) = delete;
  std::string next() {
    char buf[512];
    const ssize_t n = ::recv(socket_.fd(), buf, sizeof buf, 0);
    return n > 0 ? std::string(buf, static_cast<size_t>(n)) : std::string("<nothing>");
  }

 private:
  cobridge::test::DatagramReceiver socket_{"notify-test", 1};
};

}  // namespace

// sd_notify(3): "@name" is a socket in the abstract namespace.
TEST(Notifier, ReachesAnAbstractSocket) {
  const std::string name = "cobridge-notify-test-abstract-" + std::to_string(getpid());
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  name.copy(addr.sun_path + 1, sizeof addr.sun_path - 2);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + 1 + name.size())), 0);
  ::setenv("NOTIFY_SOCKET", ("@" + name).c_str(), 1);
  Notifier n;
  EXPECT_FALSE(n.ready());
  char buf[64];
  const ssize_t got = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
  EXPECT_EQ(std::string(buf, got > 0 ? static_cast<size_t>(got) : 0), "READY=1");
  ::unsetenv("NOTIFY_SOCKET");
  ::close(fd);
}

// A socket that is not there is the caller's to hear of (ServiceStatus logs it).
TEST(Notifier, ReportsASocketThatIsNotThere) {
  ::setenv("NOTIFY_SOCKET", "/nonexistent/cobridge-notify", 1);
  Notifier n;
  EXPECT_TRUE(n.enabled());
  EXPECT_EQ(n.ready().code, std::errc::no_such_file_or_directory);
  ::setenv("NOTIFY_SOCKET", "vsock:2:1234", 1);
  Notifier vsock;
  EXPECT_TRUE(vsock.ready());
  ::unsetenv("NOTIFY_SOCKET");
}

TEST(Notifier, DisabledWithoutNotifySocketAndSilent) {
  ::unsetenv("NOTIFY_SOCKET");
  Notifier n;
  EXPECT_FALSE(n.enabled());
  EXPECT_FALSE(n.ready());
  EXPECT_EQ(n.watchdog_period().count(), 0);
}

// sd_notify(3): READY=1, STATUS=..., WATCHDOG=1, RELOADING=1 (+MONOTONIC_USEC), STOPPING=1.
TEST(Notifier, SendsEachStateAsOneDatagram) {
  NotifySocket sock;
  Notifier n;
  ASSERT_TRUE(n.enabled());
  EXPECT_FALSE(n.ready());
  EXPECT_EQ(sock.next(), "READY=1");
  EXPECT_FALSE(n.status("2 buses, 6/6 devices online"));
  EXPECT_EQ(sock.next(), "STATUS=2 buses, 6/6 devices online");
  EXPECT_FALSE(n.watchdog());
  EXPECT_EQ(sock.next(), "WATCHDOG=1");
  EXPECT_FALSE(n.reloading());
  const std::string reload = sock.next();
  EXPECT_EQ(reload.rfind("RELOADING=1\nMONOTONIC_USEC=", 0), 0u) << reload;
  EXPECT_FALSE(n.stopping());
  EXPECT_EQ(sock.next(), "STOPPING=1");
}

// sd_watchdog_enabled(3): WATCHDOG_USEC applies only when WATCHDOG_PID is ours.
TEST(Notifier, WatchdogPeriodIsHalfOfWatchdogUsecForOurPid) {
  NotifySocket sock;
  ::setenv("WATCHDOG_USEC", "2000000", 1);
  ::setenv("WATCHDOG_PID", std::to_string(getpid()).c_str(), 1);
  Notifier mine;
  EXPECT_EQ(mine.watchdog_period().count(), 1000000);
  ::setenv("WATCHDOG_PID", "1", 1);
  Notifier other;
  EXPECT_EQ(other.watchdog_period().count(), 0);
  ::setenv("WATCHDOG_PID", "12x", 1);
  Notifier garbled;
  EXPECT_EQ(garbled.watchdog_period().count(), 0);
  ::unsetenv("WATCHDOG_PID");  // not set: the interval is ours (systemd sets it for the main process)
  Notifier unnamed;
  EXPECT_EQ(unnamed.watchdog_period().count(), 1000000);
  ::setenv("WATCHDOG_USEC", "0", 1);
  Notifier off;
  EXPECT_EQ(off.watchdog_period().count(), 0);
}
