// ControlServer: clients' SDO / NMT / LSS commands through the control
// socket, against real Unix sockets and a bus the test holds
// (held_commands.hpp). The main loop owns every connection: a command's
// result is pushed back by the bus and the loop alone answers the client.
// Checked: only the loop writes an answer, a result wakes it at once, a
// client's requests run one at a time in order, a client that leaves
// mid-request costs nobody else anything.
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

// One owning thread per connection: a finished command's result alone
// writes nothing to the client (the bus thread never touches its socket);
// the main loop's next turn writes the answer and frees the connection for
// the client's next request.
TEST(ControlServer, OnlyTheMainLoopWritesACommandsAnswer) {
  FakeHandler h;
  HeldCommands bus;
  ControlServerOptions o = fast_options();
  o.services = &bus;
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
  bus::ServiceResult r;
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
  o.services = &bus;
  // A reading client is not what is checked here: 800 kB formatted and
  // sent by the main loop take longer than 500 ms under TSan on a busy host.
  o.client_timeout = 5s;
  ServerLoop loop(h, o);
  Client c(loop.path());
  ASSERT_TRUE(c.connected());
  c.send("sdo-read line1 20 2000 0\n");
  ASSERT_TRUE(eventually([&] { return bus.held() != 0; }, 2s));
  bus::ServiceResult r;
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

namespace {

// The result hand-back tests' server: commands held by the test, a loop
// that polls for up to 10 s, so that a request or result left for the
// loop's own tick fails a test (bounded at 2 s) rather than passing late.
struct SlowTick {
  static ControlServerOptions options(HeldCommands& services) {
    ControlServerOptions o = fast_options();
    o.client_timeout = 30s;
    o.services = &services;
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
    bus::ServiceResult r;
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

}  // namespace

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

