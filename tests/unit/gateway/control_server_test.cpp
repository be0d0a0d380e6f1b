// ControlServer: the line protocol of cobridged's control socket
// (docs/operations.md "Control socket"; issue 4: `cobridge status` of a
// running daemon through a local control socket) against real Unix sockets,
// with a fake handler standing in for the bus managers. No CANopen clause is
// involved; the tests name the protocol rule they check.
#include "gateway/control_server.hpp"

#include "held_commands.hpp"
#include "unit/support/eventually.hpp"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <deque>
#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

using namespace std::chrono_literals;
using cobridge::Errc;
using cobridge::Error;
using cobridge::gateway::BusStatus;
using cobridge::gateway::ControlHandler;
using cobridge::gateway::ControlResult;
using cobridge::gateway::ControlServer;
using cobridge::gateway::ControlServerOptions;
using cobridge::gateway::DeviceState;
using cobridge::gateway::DeviceStatus;
using cobridge::gateway::RemoteBus;
using cobridge::gateway::RemoteCommand;
using cobridge::gateway::RemoteReplies;
using cobridge::gateway::RemoteResult;
using cobridge::gateway::RemoteTarget;
using cobridge::gateway::StatusReport;
using cobridge::test::eventually;
using Clock = std::chrono::steady_clock;

namespace {

class FakeHandler : public ControlHandler {
 public:
  StatusReport status() override {
    std::lock_guard lock(mutex);
    ++status_calls;
    return report;
  }
  ControlResult commission(std::string_view bus) override {
    std::lock_guard lock(mutex);
    commissioned.emplace_back(bus);
    if (!bus.empty() && bus != "line1") return {false, "unknown bus \"" + std::string(bus) + "\"", {}};
    return {true, "", {"line1"}};
  }

  std::mutex mutex;
  StatusReport report;
  int status_calls = 0;
  std::vector<std::string> commissioned;
};

StatusReport sample_report() {
  StatusReport r;
  r.gateway_id = "gw-test";
  r.version = "0.1.0";
  r.pid = 4242;
  r.ready = true;
  BusStatus b;
  b.name = "line1";
  b.interface = "vcan0";
  b.open = true;
  b.rx_frames = 1234;
  DeviceStatus d;
  d.name = "turntable";
  d.bus = "line1";
  d.node_id = 10;
  d.identity = {0x182, 0x0BE0, 0x10003, 40012};
  d.model = "RFC-4800";
  d.family = "novotechnik-rotary";
  d.state = DeviceState::operational;
  d.nmt = cobridge::canopen::NmtState::operational;
  d.online = true;
  d.since = cobridge::gateway::WallTime{std::chrono::milliseconds(1714564800123)};
  d.last_emcy_code = 0x5000;
  d.last_emcy_text = "hardware \"fault\"\n";
  d.emcy_count = 1;
  b.devices.push_back(d);
  DeviceStatus e = d;
  e.name = "winch";
  e.node_id = 0;
  e.state = DeviceState::offline;
  e.online = false;
  e.emcy_count = 0;
  e.last_emcy_code = 0;
  e.last_emcy_text.clear();
  b.devices.push_back(e);
  b.steps.push_back({"fastscan", "winch", 312.5, 167, 14, 1, {}});
  b.problems.push_back("unknown serial 99 at node 5");
  r.buses.push_back(b);
  return r;
}

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

using cobridge::gateway::testing::HeldCommands;

ControlServerOptions fast_options() {
  ControlServerOptions o;
  o.client_timeout = 500ms;
  o.max_line = 64;
  o.max_clients = 4;
  return o;
}

namespace config = cobridge::config;

// [control] writes_enabled, any caller that may connect.
config::RemoteAccess writes_open() {
  config::RemoteAccess a;
  a.control.writes_enabled = true;
  a.control.write_group.clear();
  return a;
}

// How long a test watches for something that must NOT happen (a wake-up of
// the loop, an answer written by the wrong thread): an absence holds only over a
// window. Each such test first waits for what makes the absence meaningful.
constexpr auto kAbsenceWindow = 100ms;

}  // namespace

// Protocol rule: `status` -> one line, one JSON document with every bus and
// device field `cobridge status` shows (node, identity, model, state, online,
// NMT, since, last EMCY, step timings, problems, counters).
TEST(ControlServer, StatusAnswersOneLineOfJsonWithEveryField) {
  FakeHandler h;
  h.report = sample_report();
  ServerLoop loop(h, fast_options());
  Client c(loop.path());
  ASSERT_TRUE(c.connected());
  c.send("status\n");
  const std::string a = c.line();
  ASSERT_EQ(a.front(), '{') << a;
  ASSERT_EQ(a.back(), '}') << a;
  for (const char* part :
       {"\"gateway\":\"gw-test\"", "\"pid\":4242", "\"ready\":true", "\"devices_total\":2", "\"devices_operational\":1",
        "\"name\":\"line1\"", "\"interface\":\"vcan0\"", "\"rx_frames\":1234", "\"name\":\"turntable\"",
        "\"node_id\":10", "\"serial\":40012", "\"vendor\":386", "\"model\":\"RFC-4800\"",
        "\"state\":\"operational\"", "\"online\":true", "\"since\":\"2024-05-01T12:00:00.123Z\"",
        "\"last_emcy\":{\"code\":20480,\"text\":\"hardware \\\"fault\\\"\\n\"}", "\"node_id\":null",
        "\"state\":\"offline\"", "\"last_emcy\":null", "\"step\":\"fastscan\"", "\"ms\":312.500",
        "\"exchanges\":167,\"timeouts\":14,\"restarts\":1",
        "\"problems\":[\"unknown serial 99 at node 5\"]"}) {
    EXPECT_NE(a.find(part), std::string::npos) << part << " missing in " << a;
  }
  // Several requests on one connection, each answered in turn.
  c.send("status\nstatus\n");
  EXPECT_EQ(c.line().front(), '{');
  EXPECT_EQ(c.line().front(), '{');
}

// Protocol rule: `commission [BUS]` triggers the handler (request_commission
// of that bus, or of every bus); a refusal comes back as the one Error shape
// (issue 13 item 4): {"ok":false,"error":{"code":...,"where":...,"message":...}}.
TEST(ControlServer, CommissionReachesTheHandlerAndErrorsAreJson) {
  FakeHandler h;
  HeldCommands bus;
  bus.set_access(writes_open());
  ControlServerOptions o = fast_options();
  o.remote = &bus;
  ServerLoop loop(h, o);
  Client c(loop.path());
  c.send("commission\n");
  EXPECT_EQ(c.line(), "{\"ok\":true,\"buses\":[\"line1\"]}");
  c.send("commission line1\n");
  EXPECT_EQ(c.line(), "{\"ok\":true,\"buses\":[\"line1\"]}");
  c.send("commission nosuch\n");
  EXPECT_EQ(c.line(),
            "{\"ok\":false,\"error\":{\"code\":\"not_found\",\"where\":\"\",\"message\":\"unknown bus \\\"nosuch\\\"\"}}");
  c.send("commission a b\n");
  EXPECT_NE(c.line().find("\"code\":\"invalid_argument\",\"where\":\"\",\"message\":\"usage"), std::string::npos);
  c.send("reboot\n");
  EXPECT_NE(c.line().find("unknown command \\\"reboot\\\""), std::string::npos);
  std::lock_guard lock(h.mutex);
  EXPECT_EQ(h.commissioned, (std::vector<std::string>{"", "line1", "nosuch"}));
}

// Issue 25, item 3: `commission` reassigns node-IDs, a bus write: with
// [control] writes_enabled off, or a caller outside write_group, it is
// refused (permission_denied) and the handler never called.
TEST(ControlServer, CommissionIsUnderTheWritePolicy) {
  FakeHandler h;
  HeldCommands bus;
  ControlServerOptions o = fast_options();
  o.remote = &bus;
  ServerLoop loop(h, o);
  Client c(loop.path());
  c.send("commission\n");  // no configuration at all
  EXPECT_NE(c.line().find("\"code\":\"permission_denied\",\"where\":\"every bus\""), std::string::npos);
  config::RemoteAccess closed = writes_open();
  closed.control.writes_enabled = false;
  bus.set_access(closed);
  c.send("commission line1\n");
  EXPECT_NE(c.line().find("writes_enabled = false"), std::string::npos);
  if (::geteuid() != 0) {
    // As a caller that is neither root nor the daemon's user: a group nobody is in.
    config::RemoteAccess grouped = writes_open();
    grouped.control.write_group = "cobridge-test-nosuch-group";
    bus.set_access(grouped);
    c.send("commission line1\n");
    EXPECT_NE(c.line().find("permission_denied"), std::string::npos);
  }
  bus.set_access(writes_open());
  c.send("commission line1\n");
  EXPECT_EQ(c.line(), "{\"ok\":true,\"buses\":[\"line1\"]}");
  std::lock_guard lock(h.mutex);
  EXPECT_EQ(h.commissioned, (std::vector<std::string>{"line1"}));
}

// Protocol rule: a client trickling one byte at a time cannot hold the
// daemon up: others are answered meanwhile, and the trickler is cut off once
// its line is not complete within the client timeout.
TEST(ControlServer, TricklingClientDoesNotBlockAnotherAndIsCutOff) {
  FakeHandler h;
  h.report = sample_report();
  ServerLoop loop(h, fast_options());
  Client slow(loop.path());
  ASSERT_TRUE(slow.connected());
  const auto start = Clock::now();
  bool slow_closed = false;
  for (int i = 0; i < 12 && !slow_closed; ++i) {
    slow.send("s");
    Client fast(loop.path());
    const auto t0 = Clock::now();
    fast.send("status\n");
    const std::string a = fast.line(1000ms);
    EXPECT_EQ(a.front(), '{') << a;
    EXPECT_LT(Clock::now() - t0, 200ms);
    slow_closed = slow.closed_within(100ms);
  }
  EXPECT_TRUE(slow_closed);
  const auto lived = Clock::now() - start;
  EXPECT_GE(lived, 450ms);
  EXPECT_LT(lived, 1500ms);
  EXPECT_NE(slow.received().find("not completed within 500 ms"), std::string::npos) << slow.received();
}

// Protocol rule: a client that connects and says nothing is closed after the
// client timeout, and is not counted as a connection any more.
TEST(ControlServer, SilentClientIsClosedAfterTheTimeout) {
  FakeHandler h;
  ServerLoop loop(h, fast_options());
  Client quiet(loop.path());
  ASSERT_TRUE(quiet.connected());
  EXPECT_FALSE(quiet.closed_within(300ms));
  EXPECT_TRUE(quiet.closed_within(700ms));
  // The loop counts its clients after the turn that closed this one.
  EXPECT_TRUE(eventually([&] { return loop.clients() == 0u; }, 2s)) << loop.clients() << " clients counted";
}

// Protocol rule: a line longer than max_line is answered with an error and
// the connection closed; garbage with a newline is an unknown command, echoed
// only as printable ASCII, and the connection stays usable.
TEST(ControlServer, OverlongLineIsRejectedAndGarbageIsAnError) {
  FakeHandler h;
  h.report = sample_report();
  ServerLoop loop(h, fast_options());
  Client garbage(loop.path());
  garbage.send(std::string("\x01\xff\x7f\x00zz\n", 7));
  const std::string a = garbage.line();
  EXPECT_NE(a.find("\"message\":\"unknown command \\\"???"), std::string::npos) << a;
  garbage.send("status\n");
  EXPECT_EQ(garbage.line().front(), '{');

  Client longer(loop.path());
  longer.send(std::string(200, 'x'));  // no newline at all
  EXPECT_EQ(longer.line(), "{\"ok\":false,\"error\":{\"code\":\"invalid_argument\",\"where\":\"\",\"message\":"
                           "\"request line longer than 64 bytes\"}}");
  EXPECT_TRUE(longer.closed_within(300ms));

  Client exact(loop.path());  // 64 bytes is still a line
  exact.send(std::string(64, 'y') + "\n");
  EXPECT_NE(exact.line().find("unknown command"), std::string::npos);
}

// Protocol rule: at most max_clients connections; the next one is told so
// and closed, and the ones inside are still served.
TEST(ControlServer, ConnectionsBeyondTheLimitAreRefused) {
  FakeHandler h;
  ServerLoop loop(h, fast_options());
  std::vector<std::unique_ptr<Client>> inside;
  for (int i = 0; i < 4; ++i) inside.push_back(std::make_unique<Client>(loop.path()));
  // All four accepted (connect() returns once queued): the next is the fifth.
  ASSERT_TRUE(eventually([&] { return loop.clients() == 4u; }, 2s)) << loop.clients() << " of 4 accepted";
  Client extra(loop.path());
  EXPECT_EQ(extra.line(), "{\"ok\":false,\"error\":{\"code\":\"unavailable\",\"where\":\"\",\"message\":"
                          "\"too many clients (limit 4)\"}}");
  inside[0]->send("status\n");
  EXPECT_NE(inside[0]->line().find("\"gateway\":"), std::string::npos);
}

// Protocol rule: a request without newline followed by end of input still
// counts (`printf status | nc -U`).
TEST(ControlServer, LastLineWithoutNewlineIsAnswered) {
  FakeHandler h;
  h.report = sample_report();
  ServerLoop loop(h, fast_options());
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  loop.path().string().copy(addr.sun_path, sizeof addr.sun_path - 1);
  ASSERT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  ASSERT_EQ(::send(fd, "status", 6, MSG_NOSIGNAL), 6);
  ::shutdown(fd, SHUT_WR);
  std::string all;
  char buf[4096];
  timeval tv{2, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  for (ssize_t n; (n = ::recv(fd, buf, sizeof buf, 0)) > 0;) all.append(buf, static_cast<std::size_t>(n));
  ::close(fd);
  EXPECT_NE(all.find("\"gateway\":\"gw-test\""), std::string::npos);
  EXPECT_EQ(all.back(), '\n');
}

// Socket file rules: mode 0660, the directory created; a stale socket file
// (no listener) is replaced; a live one (another daemon) is refused and left.
TEST(ControlServer, SocketModeStaleFileAndLiveDaemon) {
  FakeHandler h;
  const auto dir = std::filesystem::path("/tmp") / ("cobridge-ctl-stale-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const auto path = dir / "sub" / "control.sock";
  {
    // A stale socket: bound, then its owner gone.
    std::filesystem::create_directories(path.parent_path());
    const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    path.string().copy(addr.sun_path, sizeof addr.sun_path - 1);
    ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    ::close(fd);
  }
  ControlServer first(h);
  const Error opened = first.open(path);
  ASSERT_FALSE(opened) << opened.to_string();
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_TRUE(S_ISSOCK(st.st_mode));
  EXPECT_EQ(st.st_mode & 0777, 0660u);

  ControlServer second(h);
  const Error taken = second.open(path);
  EXPECT_EQ(taken.code, std::errc::address_in_use);
  EXPECT_EQ(taken.kind, Errc::kUnavailable);
  EXPECT_EQ(taken.where, path.string());
  EXPECT_NE(taken.message.find("another daemon"), std::string::npos) << taken.to_string();
  EXPECT_TRUE(std::filesystem::exists(path));  // the first one's socket is left alone

  first.close();
  EXPECT_FALSE(std::filesystem::exists(path));  // removed on close

  // Not a socket: never deleted.
  { std::FILE* f = std::fopen(path.c_str(), "w"); std::fclose(f); }
  const Error not_socket = second.open(path);
  EXPECT_EQ(not_socket.code, std::errc::file_exists);
  EXPECT_EQ(not_socket.kind, Errc::kInvalidArgument);
  EXPECT_EQ(not_socket.where, path.string());
  EXPECT_TRUE(std::filesystem::is_regular_file(path));
  std::filesystem::remove_all(dir);
}

// sd_notify STATUS= text (docs/operations.md): buses and operational devices.
TEST(ControlServer, SummaryCountsOperationalDevices) {
  auto r = sample_report();
  EXPECT_EQ(cobridge::gateway::summary(r.buses), "1 bus, 1/2 devices operational");
  BusStatus missing;
  missing.name = "line2";
  missing.interface = "can1";
  r.buses.push_back(missing);
  // Issue 10, item 8: the bus whose adapter is missing is named.
  EXPECT_EQ(cobridge::gateway::summary(r.buses),
            "2 buses (1 open; waiting for line2 (can1)), 1/2 devices operational");
}

// One owning thread per connection: a finished command's result alone
// writes nothing to the client (the bus thread never touches its socket);
// the main loop's next turn writes the answer and frees the connection for
// the client's next request.
TEST(ControlServer, OnlyTheMainLoopWritesACommandsAnswer) {
  FakeHandler h;
  HeldCommands bus;
  ControlServerOptions o = fast_options();
  o.remote = &bus;
  const auto dir = std::filesystem::path("/tmp") / ("cobridge-ctl-owner-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  ControlServer server(h, o);
  ASSERT_FALSE(server.open(dir / "control.sock"));
  Client c(dir / "control.sock");
  ASSERT_TRUE(c.connected());
  // Turns the main loop until the bus holds `n` commands (2 s at most).
  auto run_until_held = [&](std::size_t n) {
    (void)eventually(
        [&] {
          (void)server.process(Clock::now());
          return bus.held() >= n;
        },
        2s);
    return bus.held() == n;
  };
  // Turns the main loop until the client has an answer line (2 s at most).
  auto run_until_answered = [&] {
    std::string got = "<timeout>";
    (void)eventually(
        [&] {
          (void)server.process(Clock::now());
          got = c.line(10ms);
          return got != "<timeout>";
        },
        2s);
    return got;
  };
  c.send("sdo-read line1 20 1018 4\n");
  ASSERT_TRUE(run_until_held(1));
  RemoteResult r;
  r.data = {0xD1, 0x07, 0x00, 0x00};
  ASSERT_TRUE(bus.finish(r));
  EXPECT_EQ(c.line(kAbsenceWindow), "<timeout>") << "the answer was written by a thread other than the owner";
  EXPECT_EQ(run_until_answered(), "{\"ok\":true,\"via\":\"daemon\",\"bus\":\"line1\",\"node\":20,\"index\":4120,"
                                  "\"sub\":4,\"size\":4,\"hex\":\"D1070000\",\"value\":2001}");
  // The connection is free again: the next request is taken.
  c.send("sdo-read line1 20 1018 1\n");
  ASSERT_TRUE(run_until_held(1));
  r.data = {0x2A, 0x00, 0x00, 0x00};
  ASSERT_TRUE(bus.finish(r));
  EXPECT_NE(run_until_answered().find("\"sub\":1,\"size\":4,\"hex\":\"2A000000\",\"value\":42}"), std::string::npos);
  server.close();
  std::filesystem::remove_all(dir);
}

// An answer the client's socket does not take at once (here longer than its
// buffer) is finished by the main loop: one whole line, nothing lost or
// doubled, and the next request is served after it.
TEST(ControlServer, AnswerTheSocketCannotTakeIsFinishedByTheMainLoop) {
  FakeHandler h;
  HeldCommands bus;
  ControlServerOptions o = fast_options();
  o.remote = &bus;
  ServerLoop loop(h, o);
  Client c(loop.path());
  ASSERT_TRUE(c.connected());
  c.send("sdo-read line1 20 2000 0\n");
  ASSERT_TRUE(eventually([&] { return bus.held() != 0; }, 2s));
  RemoteResult r;
  r.data.assign(400000, 0xAB);
  ASSERT_TRUE(bus.finish(r));
  const std::string a = c.line(5000ms);
  const std::string head = "{\"ok\":true,\"via\":\"daemon\",\"bus\":\"line1\",\"node\":20,\"index\":8192,"
                           "\"sub\":0,\"size\":400000,\"hex\":\"";
  ASSERT_EQ(a.size(), head.size() + 800000 + 2) << a.substr(0, 200);
  EXPECT_EQ(a.substr(0, head.size()), head);
  EXPECT_EQ(a.find_first_not_of("AB", head.size()), a.size() - 2);
  EXPECT_EQ(a.substr(a.size() - 2), "\"}");
  c.send("sdo-read line1 20 1018 4\n");
  ASSERT_TRUE(eventually([&] { return bus.held() != 0; }, 2s));
  r.data = {0xD1, 0x07, 0x00, 0x00};
  ASSERT_TRUE(bus.finish(r));
  EXPECT_NE(c.line(2000ms).find("\"value\":2001}"), std::string::npos);
}

// The result hand-back tests' server: commands held by the test, a loop
// that polls for up to 10 s, so that a request or result left for the
// loop's own tick fails a test (bounded at 2 s) rather than passing late.
struct SlowTick {
  static ControlServerOptions options(HeldCommands& remote) {
    ControlServerOptions o = fast_options();
    o.client_timeout = 30s;
    o.remote = &remote;
    return o;
  }
  // Whether the bus holds `n` commands within 2 s.
  bool held(std::size_t n) {
    (void)eventually([&] { return bus.held() >= n; }, 2s);
    return bus.held() == n;
  }
  // Waits (2 s at most) until the loop waits in poll, the turn that took
  // the last request over; returns its entries into poll then (0: never).
  std::size_t settled() {
    std::size_t polls = 0;
    (void)eventually([&] { return (polls = loop.waiting_in_poll()) != 0; }, 2s);
    return polls;
  }
  // Whether the loop, settled after `polls` entries into poll, woke, took
  // its turn for what woke it and is back in poll, within 2 s. In these
  // tests nothing but the test's own step wakes it (the tick is 10 s).
  bool turned(std::size_t polls) {
    return eventually([&] { return loop.polls() > polls; }, 2s);
  }
  // Ends the oldest held command with a 4-byte value (little-endian).
  bool finish(std::uint32_t value) {
    RemoteResult r;
    r.data = {static_cast<std::uint8_t>(value), static_cast<std::uint8_t>(value >> 8),
              static_cast<std::uint8_t>(value >> 16), static_cast<std::uint8_t>(value >> 24)};
    return bus.finish(r);
  }
  FakeHandler h;
  HeldCommands bus;
  ServerLoop loop{h, options(bus), 10s};
};

// The oldest held command ends with 2001, which `c` reads; then its next
// request (already sent) must be taken, and its answer 42 read.
void answer_then_take_next(SlowTick& t, Client& c, const char* not_taken) {
  ASSERT_TRUE(t.finish(2001));
  EXPECT_NE(c.line(2000ms).find("\"value\":2001}"), std::string::npos);
  ASSERT_TRUE(t.held(1)) << not_taken;
  ASSERT_TRUE(t.finish(42));
  EXPECT_NE(c.line(2000ms).find("\"value\":42}"), std::string::npos);
}

// A command's result wakes the main loop at once (its reply eventfd; the
// tick here is 10 s): the answer goes out and the client's next request is
// taken without waiting for a tick.
TEST(ControlServer, AResultWakesTheLoopAndTheNextRequestIsTakenAtOnce) {
  SlowTick t;
  Client c(t.loop.path());
  ASSERT_TRUE(c.connected());
  c.send("sdo-read line1 20 1018 4\n");
  ASSERT_TRUE(t.held(1));
  ASSERT_NE(t.settled(), 0u) << "the loop did not go back to poll";
  ASSERT_TRUE(t.finish(2001));
  EXPECT_NE(c.line(2000ms).find("\"value\":2001}"), std::string::npos);
  c.send("sdo-read line1 20 1018 1\n");
  ASSERT_TRUE(t.held(1)) << "the next request was not taken within 2 s";
  ASSERT_TRUE(t.finish(42));
  EXPECT_NE(c.line(2000ms).find("\"value\":42}"), std::string::npos);
}

// A client that sends its next request before its result came back: the
// loop leaves the waiting client's socket alone (no wake-up for it, no
// read), takes the request when the result comes, and both answers arrive
// in order.
TEST(ControlServer, ARequestBeforeTheResultIsTakenWhenTheResultComes) {
  SlowTick t;
  Client c(t.loop.path());
  ASSERT_TRUE(c.connected());
  c.send("sdo-read line1 20 1018 4\n");
  ASSERT_TRUE(t.held(1));
  const std::size_t polls = t.settled();
  ASSERT_NE(polls, 0u) << "the loop did not go back to poll";
  c.send("sdo-read line1 20 1018 1\n");
  std::this_thread::sleep_for(kAbsenceWindow);
  EXPECT_EQ(t.loop.polls(), polls) << "the loop woke for a client whose command runs";
  answer_then_take_next(t, c, "the pipelined request was not taken within 2 s");
}

// Two clients, A with its next request sent before its result: B's result
// is answered to B alone, and A's, coming after, still takes A's next
// request at once (each result wakes the loop; the tick is 10 s).
TEST(ControlServer, TwoClientsResultsEachReachTheirClientAtOnce) {
  SlowTick t;
  Client a(t.loop.path());
  Client b(t.loop.path());
  ASSERT_TRUE(a.connected() && b.connected());
  b.send("sdo-read line1 21 1018 4\n");
  ASSERT_TRUE(t.held(1));
  a.send("sdo-read line1 20 1018 4\n");
  ASSERT_TRUE(t.held(2));
  a.send("sdo-read line1 20 1018 1\n");
  ASSERT_TRUE(t.finish(1));  // B's
  EXPECT_NE(b.line(2000ms).find("\"value\":1}"), std::string::npos);
  EXPECT_EQ(a.line(kAbsenceWindow), "<timeout>") << "A was answered with B's result";
  answer_then_take_next(t, a, "A's next request was not taken within 2 s");  // A's first
}

// A client that leaves while its command runs: the command ends on the bus
// as any other (the bus thread holds nothing of the client), its result is
// dropped with the connection, and the other clients are served.
TEST(ControlServer, AClientThatLeavesMidRequestIsClosedAndOthersAreServed) {
  SlowTick t;
  auto gone = std::make_unique<Client>(t.loop.path());
  Client stays(t.loop.path());
  ASSERT_TRUE(gone->connected() && stays.connected());
  gone->send("sdo-read line1 20 1018 4\n");
  ASSERT_TRUE(t.held(1));
  ASSERT_TRUE(eventually([&] { return t.loop.clients() == 2; }, 2s));
  gone.reset();
  stays.send("sdo-read line1 21 1018 4\n");
  ASSERT_TRUE(t.held(2));
  ASSERT_TRUE(t.finish(2001));  // the departed client's
  EXPECT_TRUE(eventually([&] { return t.loop.clients() == 1; }, 2s)) << "the departed client was kept";
  ASSERT_TRUE(t.finish(42));
  EXPECT_NE(stays.line(2000ms).find("\"value\":42}"), std::string::npos);
}

// Pipelined requests: one command of a client runs at a time, in the order
// sent, and the answers come in that order.
TEST(ControlServer, PipelinedRequestsRunOneAtATimeInOrder) {
  SlowTick t;
  Client c(t.loop.path());
  ASSERT_TRUE(c.connected());
  c.send("sdo-read line1 20 1018 4\nsdo-read line1 20 1018 1\n");
  ASSERT_TRUE(t.held(1));
  std::this_thread::sleep_for(kAbsenceWindow);
  ASSERT_EQ(t.bus.held(), 1U) << "the second request ran beside the first";
  ASSERT_EQ(t.bus.oldest()->sub, 4);
  ASSERT_TRUE(t.finish(2001));
  EXPECT_NE(c.line(2000ms).find("\"sub\":4,"), std::string::npos);
  ASSERT_TRUE(t.held(1));
  ASSERT_EQ(t.bus.oldest()->sub, 1);
  ASSERT_TRUE(t.finish(42));
  EXPECT_NE(c.line(2000ms).find("\"sub\":1,"), std::string::npos);
}
