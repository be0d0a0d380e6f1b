// DatagramReceiver: a Unix datagram socket bound to a fresh path under /tmp,
// standing in for a systemd socket (journald's, $NOTIFY_SOCKET) in the sys/
// tests. Removed again when it goes.
//
// Thread: the test's.
#pragma once

#include <sys/socket.h>
#include <sys/time.h>
#include <sys/un.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <string>

namespace cobridge::test {

class DatagramReceiver {
 public:
  // `name` makes the path: /tmp/cobridge-<name>-<pid>; a read waits `timeout_s`.
  DatagramReceiver(const std::string& name, int timeout_s) {
    path_ = "/tmp/cobridge-" + name + "-" + std::to_string(::getpid());
    ::unlink(path_.c_str());
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    path_.copy(addr.sun_path, sizeof addr.sun_path - 1);
    EXPECT_EQ(::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0) << path_;
    timeval tv{timeout_s, 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  }
  ~DatagramReceiver() {
    ::close(fd_);
    ::unlink(path_.c_str());
  }
  DatagramReceiver(const DatagramReceiver&) = delete;
  DatagramReceiver& operator=(const DatagramReceiver&) = delete;

  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] int fd() const { return fd_; }

 private:
  std::string path_;
  int fd_ = -1;
};

}  // namespace cobridge::test
