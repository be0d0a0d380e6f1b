// The control socket tests' fixture (control_server_test.cpp,
// control_server_commands_test.cpp): a fake handler standing in for the bus
// managers, the server run on a thread the way cobridged's main loop runs
// it, and a client on a real Unix socket.
//
// Threads: ServerLoop runs the server on its own thread; the rest is the
// test's thread (FakeHandler under its mutex, read by both).
#pragma once

#include "control/control_server.hpp"

#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <filesystem>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace cobridge::control::testing {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

class FakeHandler : public ControlHandler {
 public:
  StatusReport status() override {
    std::lock_guard lock(mutex);
    ++status_calls;
    return report;
  }
  Result<std::vector<std::string>> commission(std::string_view bus) override {
    std::lock_guard lock(mutex);
    commissioned.emplace_back(bus);
    if (!bus.empty() && bus != "line1") return Error(Errc::kNotFound, "unknown bus \"" + std::string(bus) + "\"");
    return std::vector<std::string>{"line1"};
  }
  Result<std::vector<std::string>> capture_now(std::string_view bus) override {
    std::lock_guard lock(mutex);
    captured.emplace_back(bus);
    return std::vector<std::string>{"line1"};
  }
  Result<std::vector<std::string>> acknowledge(std::string_view device, const std::string& caller) override {
    std::lock_guard lock(mutex);
    acknowledged.emplace_back(std::string(device) + " by " + caller);
    return std::vector<std::string>{"line1"};
  }

  std::mutex mutex;
  StatusReport report;
  int status_calls = 0;
  std::vector<std::string> commissioned;
  std::vector<std::string> captured;
  std::vector<std::string> acknowledged;
};

// Runs the server the way cobridged's main loop does (app/daemon.cpp serve()).
class ServerLoop {
 public:
  // `max_wait`: the longest poll; cobridged's is ServiceStatus::kTick.
  ServerLoop(FakeHandler& handler, ControlServerOptions options, std::chrono::milliseconds max_wait = 20ms)
      : path_(std::filesystem::path("/tmp") / ("cobridge-ctl-test-" + std::to_string(::getpid())) / "control.sock"),
        server_(handler, options) {
    std::filesystem::remove_all(path_.parent_path());
    const Error e = server_.open(path_);
    EXPECT_FALSE(e) << e.to_string();
    thread_ = std::thread([this, max_wait] {
      // As cobridged's loop: process, poll, tell the server what poll saw
      // (so only ready descriptors are touched: poll_slot.hpp).
      std::vector<pollfd> fds;
      while (!stop_) {
        const auto next = server_.process(Clock::now());
        clients_ = server_.clients();
        fds.clear();
        server_.add_poll_fds(fds);
        auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(next - Clock::now());
        if (next == cobridge::canopen::kNever || wait > max_wait) wait = max_wait;
        if (wait < 0ms) wait = 0ms;
        ++polls_;
        ::poll(fds.data(), fds.size(), static_cast<int>(wait.count()));
        server_.note_ready(fds);
        ++turns_;
      }
      server_.close();
    });
  }
  ~ServerLoop() {
    stop_ = true;
    // A connection ends the loop's poll at once (it may wait 10 s).
    const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    path_.string().copy(addr.sun_path, sizeof addr.sun_path - 1);
    (void)::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);
    ::close(fd);
    thread_.join();
    std::filesystem::remove_all(path_.parent_path());
  }
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  [[nodiscard]] std::size_t clients() const { return clients_; }
  // Wake-ups of the loop so far.
  [[nodiscard]] std::size_t turns() const { return turns_; }
  // Entries into poll so far: one more than turns() while the loop waits
  // there, so a count taken then grows only once a wake-up's turn is over.
  [[nodiscard]] std::size_t polls() const { return polls_; }
  // polls() while the loop waits in poll (its turn, with all it did, is
  // over), 0 while it is in a turn. polls_ is read first: a wake-up between
  // the two reads shows as a turn.
  [[nodiscard]] std::size_t waiting_in_poll() const {
    const std::size_t p = polls_;
    return p == turns_ + 1 ? p : 0;
  }

 private:
  std::filesystem::path path_;
  ControlServer server_;
  std::atomic<bool> stop_{false};
  std::atomic<std::size_t> clients_{0};
  std::atomic<std::size_t> turns_{0};
  std::atomic<std::size_t> polls_{0};
  std::thread thread_;
};

class Client {
 public:
  explicit Client(const std::filesystem::path& path) {
    fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    path.string().copy(addr.sun_path, sizeof addr.sun_path - 1);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
  }
  ~Client() { ::close(fd_); }
  [[nodiscard]] bool connected() const { return connected_; }
  void send(std::string_view s) { (void)::send(fd_, s.data(), s.size(), MSG_NOSIGNAL); }
  // One answer line, or "<timeout>" / "<closed>".
  std::string line(std::chrono::milliseconds timeout = 2000ms) {
    const auto deadline = Clock::now() + timeout;
    while (true) {
      const auto nl = buffer_.find('\n');
      if (nl != std::string::npos) {
        std::string l = buffer_.substr(0, nl);
        buffer_.erase(0, nl + 1);
        return l;
      }
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
      if (left <= 0ms) return "<timeout>";
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) continue;
      char buf[65536];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) return "<closed>";
      buffer_.append(buf, static_cast<std::size_t>(n));
    }
  }
  // True when the server closed the connection within `timeout`.
  bool closed_within(std::chrono::milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    while (Clock::now() < deadline) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 10) > 0) {
        char buf[4096];
        const ssize_t n = ::recv(fd_, buf, sizeof buf, MSG_DONTWAIT);
        if (n == 0 || (n < 0 && errno != EAGAIN)) return true;
        if (n > 0) buffer_.append(buf, static_cast<std::size_t>(n));
      }
    }
    return false;
  }
  [[nodiscard]] const std::string& received() const { return buffer_; }

 private:
  int fd_ = -1;
  bool connected_ = false;
  std::string buffer_;
};

inline ControlServerOptions fast_options() {
  ControlServerOptions o;
  o.client_timeout = 500ms;
  o.max_line = 64;
  o.max_clients = 4;
  return o;
}

// [control] writes_enabled, any caller that may connect.
inline config::ServiceAccess writes_open() {
  config::ServiceAccess a;
  a.control.writes_enabled = true;
  a.control.write_group.clear();
  return a;
}

// How long a test watches for something that must NOT happen (a wake-up of
// the loop, an answer written by the wrong thread): an absence holds only over a
// window. Each such test first waits for what makes the absence meaningful.
constexpr auto kAbsenceWindow = 100ms;


}  // namespace cobridge::control::testing

// The names the control-server tests use, for both of their files.
using namespace std::chrono_literals;
using cobridge::Errc;
using cobridge::Error;
using cobridge::bus::BusStatus;
using cobridge::control::ControlHandler;
using cobridge::control::ControlServer;
using cobridge::control::ControlServerOptions;
using cobridge::bus::DeviceState;
using cobridge::bus::DeviceStatus;
using cobridge::bus::ServiceBus;
using cobridge::bus::ServiceRequest;
using cobridge::bus::ServiceReplies;
using cobridge::bus::ServiceResult;
using cobridge::bus::ServiceTarget;
using cobridge::control::StatusReport;
using Clock = std::chrono::steady_clock;
using cobridge::control::testing::Client;
using cobridge::control::testing::FakeHandler;
using cobridge::control::testing::ServerLoop;
using cobridge::control::testing::fast_options;
using cobridge::control::testing::kAbsenceWindow;
