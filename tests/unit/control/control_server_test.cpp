// ControlServer: the line protocol of cobridged's control socket
// (docs/operations.md "Control socket": `cobridge status` of a
// running daemon through a local control socket) against real Unix sockets,
// with a fake handler standing in for the bus managers. No CANopen clause is
// involved; the tests name the protocol rule they check.
#include "control/control_server.hpp"

#include "control_server_fixture.hpp"
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

namespace bus = cobridge::bus;

// The names every control-server test uses: tests/unit/control/control_server_fixture.hpp.
using cobridge::control::testing::HeldCommands;
using cobridge::test::eventually;
using cobridge::control::testing::writes_open;
namespace config = cobridge::config;

namespace {

StatusReport sample_report() {
  StatusReport r;
  r.gateway_id = "gw-test";
  r.version = "0.1.0";
  r.pid = 4242;
  r.ready = true;
  bus::BusStatus b;
  b.name = "line1";
  b.interface = "vcan0";
  b.open = true;
  b.rx_frames = 1234;
  bus::DeviceStatus d;
  d.name = "turntable";
  d.bus = "line1";
  d.node_id = 10;
  d.identity = {0x182, 0x0BE0, 0x10003, 40012};
  d.model = "RFC-4800";
  d.family = "novotechnik-rotary";
  d.state = bus::DeviceState::operational;
  d.nmt = cobridge::canopen::NmtState::operational;
  d.online = true;
  d.since = cobridge::bus::WallTime{std::chrono::milliseconds(1714564800123)};
  d.last_emcy_code = 0x5000;
  d.last_emcy_text = "hardware \"fault\"\n";
  d.emcy_count = 1;
  b.devices.push_back(d);
  bus::DeviceStatus e = d;
  e.name = "winch";
  e.node_id = 0;
  e.state = bus::DeviceState::offline;
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
// of that bus, or of every bus); a refusal comes back as the one Error shape:
// {"ok":false,"error":{"code":...,"where":...,"message":...}}.
TEST(ControlServer, CommissionReachesTheHandlerAndErrorsAreJson) {
  FakeHandler h;
  HeldCommands bus;
  bus.set_access(writes_open());
  ControlServerOptions o = fast_options();
  o.services = &bus;
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

// A control-socket write that is no bus command (`commission`, `capture-now`)
// under the write policy: refused (permission_denied, where = the bus or
// "every bus") with no configuration at all, with [control] writes_enabled
// off, and (when not run as root) for a caller outside write_group; then,
// with writes open, the answer to `VERB line1`.
std::string answer_under_the_write_policy(FakeHandler& h, const std::string& verb) {
  HeldCommands bus;
  ControlServerOptions o = fast_options();
  o.services = &bus;
  ServerLoop loop(h, o);
  Client c(loop.path());
  c.send(verb + " line1\n");  // no configuration at all
  EXPECT_NE(c.line().find("\"code\":\"permission_denied\",\"where\":\"bus 'line1'\""), std::string::npos);
  config::ServiceAccess closed = writes_open();
  closed.control.writes_enabled = false;
  bus.set_access(closed);
  c.send(verb + "\n");
  const std::string refused = c.line();
  EXPECT_NE(refused.find("writes_enabled = false"), std::string::npos) << refused;
  EXPECT_NE(refused.find("\"where\":\"every bus\""), std::string::npos) << refused;
  if (::geteuid() != 0) {
    // As a caller that is neither root nor the daemon's user: a group nobody is in.
    config::ServiceAccess grouped = writes_open();
    grouped.control.write_group = "cobridge-test-nosuch-group";
    bus.set_access(grouped);
    c.send(verb + " line1\n");
    EXPECT_NE(c.line().find("permission_denied"), std::string::npos);
  }
  bus.set_access(writes_open());
  c.send(verb + " line1\n");
  return c.line();
}

// `commission` reassigns node-IDs, a bus write: refused under the write
// policy and the handler never called then.
TEST(ControlServer, CommissionIsUnderTheWritePolicy) {
  FakeHandler h;
  EXPECT_EQ(answer_under_the_write_policy(h, "commission"), "{\"ok\":true,\"buses\":[\"line1\"]}");
  std::lock_guard lock(h.mutex);
  EXPECT_EQ(h.commissioned, (std::vector<std::string>{"line1"}));
}

// `capture-now` writes the disk and a file of every frame
// of the bus: under the write policy like `commission`, the handler never
// called while refused; taken once writes are open, with the capture's note
// in the answer.
TEST(ControlServer, CaptureNowIsUnderTheWritePolicy) {
  FakeHandler h;
  const std::string taken = answer_under_the_write_policy(h, "capture-now");
  EXPECT_NE(taken.find("\"ok\":true,\"buses\":[\"line1\"]"), std::string::npos) << taken;
  EXPECT_NE(taken.find("capture_after_s"), std::string::npos) << taken;
  std::lock_guard lock(h.mutex);
  EXPECT_EQ(h.captured, (std::vector<std::string>{"line1"}));
}

// `acknowledge DEVICE` lets the gateway write a contested configuration
// again (bus/restore_guard.hpp): a write like `commission`, refused with
// writes closed (the handler never called), taken once they are open, and
// the caller handed on for the device's timeline.
TEST(ControlServer, AcknowledgeIsUnderTheWritePolicy) {
  FakeHandler h;
  HeldCommands bus;
  ControlServerOptions o = fast_options();
  o.services = &bus;
  ServerLoop loop(h, o);
  Client c(loop.path());
  config::ServiceAccess closed = writes_open();
  closed.control.writes_enabled = false;
  bus.set_access(closed);
  c.send("acknowledge rot-a\n");
  const std::string refused = c.line();
  EXPECT_NE(refused.find("\"code\":\"permission_denied\",\"where\":\"device 'rot-a'\""), std::string::npos) << refused;
  {
    std::lock_guard lock(h.mutex);
    EXPECT_TRUE(h.acknowledged.empty());
  }
  bus.set_access(writes_open());
  c.send("acknowledge\n");
  EXPECT_NE(c.line().find("usage: acknowledge DEVICE"), std::string::npos);
  c.send("acknowledge rot-a\n");
  const std::string taken = c.line();
  EXPECT_NE(taken.find("\"ok\":true,\"buses\":[\"line1\"]"), std::string::npos) << taken;
  std::lock_guard lock(h.mutex);
  ASSERT_EQ(h.acknowledged.size(), 1u);
  EXPECT_EQ(h.acknowledged[0].rfind("rot-a by uid ", 0), 0u) << h.acknowledged[0];
  EXPECT_NE(h.acknowledged[0].find("(control socket)"), std::string::npos) << h.acknowledged[0];
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
  EXPECT_EQ(cobridge::control::summary(r.buses), "1 bus, 1/2 devices operational");
  bus::BusStatus missing;
  missing.name = "line2";
  missing.interface = "can1";
  r.buses.push_back(missing);
  // The bus whose adapter is missing is named.
  EXPECT_EQ(cobridge::control::summary(r.buses),
            "2 buses (1 open; waiting for line2 (can1)), 1/2 devices operational");
}

