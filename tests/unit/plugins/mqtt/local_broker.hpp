// Test helpers for the MQTT client's tests: Debian's mosquitto broker on a
// free loopback port (plain, or with the options of a configuration file),
// and one pass of the publisher thread's loop. Header-only, test code.
#pragma once

#include "mosquitto_link.hpp"

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>
#include <thread>

namespace cobridge::mqtt::test {

using Clock = std::chrono::steady_clock;

inline std::uint16_t free_port() {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  EXPECT_EQ(::bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  EXPECT_EQ(::getsockname(s, reinterpret_cast<sockaddr*>(&a), &len), 0);
  ::close(s);
  return ntohs(a.sin_port);
}

inline bool accepts(std::uint16_t port) {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(port);
  const bool ok = ::connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  ::close(s);
  return ok;
}

// Debian's broker, local only: `mosquitto -p PORT`, or `mosquitto -c FILE`
// when a configuration file is given (its listener names the port); killed
// with the object.
class Broker {
 public:
  explicit Broker(std::uint16_t port, const std::string& config_file = {}) {
    const std::string p = std::to_string(port);  // no allocation after fork
    const int null = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
    pid_ = ::fork();
    if (pid_ == 0) {
      ::dup2(null, STDOUT_FILENO);
      ::dup2(null, STDERR_FILENO);
      if (config_file.empty())
        ::execl("/usr/sbin/mosquitto", "mosquitto", "-p", p.c_str(), static_cast<char*>(nullptr));
      else
        ::execl("/usr/sbin/mosquitto", "mosquitto", "-c", config_file.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    ::close(null);
  }
  ~Broker() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    ::waitpid(pid_, nullptr, 0);
  }
  Broker(const Broker&) = delete;
  Broker& operator=(const Broker&) = delete;

 private:
  pid_t pid_ = -1;
};

// One pass of the publisher thread's loop; whether the session is up.
inline bool serviced(MosquittoLink& link) {
  link.service(Clock::now());
  return link.connected();
}

template <class Pred>
bool wait_for(Pred pred, std::chrono::milliseconds limit) {
  const auto end = Clock::now() + limit;
  while (!pred()) {
    if (Clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

}  // namespace cobridge::mqtt::test
