// AsciiServer (control/remote/ascii_server.hpp): a gateway that cannot open
// says what failed where, in the one error shape (base/error.hpp), and the
// daemon keeps running without it; the answer to a CiA 309-3 read reaches
// the client from the thread that finished it (issue 15).
#include "control/remote/ascii_server.hpp"

#include "bus/remote/connection_loan.hpp"
#include "held_commands.hpp"

#include <gtest/gtest.h>

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <deque>
#include <mutex>
#include <thread>

#include <filesystem>
#include <fstream>

namespace {

using cobridge::Errc;
using namespace cobridge::gateway;

class NoBuses final : public RemoteTarget {
 public:
  [[nodiscard]] std::vector<RemoteBus> buses() const override { return {}; }
  [[nodiscard]] cobridge::Error submit(std::string_view, RemoteCommand, std::shared_ptr<RemoteReplies>) override {
    return cobridge::Error(Errc::kNotFound, "no bus");
  }
  [[nodiscard]] std::optional<cobridge::config::RemoteAccess> access() const override { return std::nullopt; }
};

TEST(AsciiServer, BadTcpAddressNamesAddressAndPort) {
  NoBuses buses;
  AsciiServer server(buses, {});
  const auto e = server.open_tcp("localhost.example", 5000);
  ASSERT_TRUE(e);
  EXPECT_EQ(e.kind, Errc::kInvalidArgument);
  EXPECT_EQ(e.where, "localhost.example:5000");
  EXPECT_NE(e.message.find("IPv4"), std::string::npos) << e.message;
}

TEST(AsciiServer, AFileInThePlaceOfTheSocketIsLeftAlone) {
  const auto dir = std::filesystem::temp_directory_path() / ("cobridge-ascii-test-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto path = dir / "ascii.sock";
  std::ofstream(path) << "not a socket";
  NoBuses buses;
  AsciiServer server(buses, {});
  const auto e = server.open_unix(path);
  ASSERT_TRUE(e);
  EXPECT_EQ(e.kind, Errc::kInvalidArgument);
  EXPECT_EQ(e.where, path.string());
  EXPECT_TRUE(std::filesystem::is_regular_file(path));  // not deleted
  std::filesystem::remove_all(dir);
}

TEST(AsciiServer, OpensOnAFreshPathWithMode0660) {
  const auto dir = std::filesystem::temp_directory_path() / ("cobridge-ascii-ok-" + std::to_string(::getpid()));
  NoBuses buses;
  AsciiServer server(buses, {});
  const auto e = server.open_unix(dir / "ascii.sock");
  ASSERT_FALSE(e) << e.to_string();
  const auto perms = std::filesystem::status(dir / "ascii.sock").permissions();
  EXPECT_EQ(perms & std::filesystem::perms::all,
            std::filesystem::perms::owner_read | std::filesystem::perms::owner_write |
                std::filesystem::perms::group_read | std::filesystem::perms::group_write);
  server.close();
  EXPECT_FALSE(std::filesystem::exists(dir / "ascii.sock"));
  std::filesystem::remove_all(dir);
}

using cobridge::gateway::testing::HeldCommands;

// What a client reads within `ms`, without the server turning meanwhile, as
// `cocomm` reads an answer: up to CR LF (CiA 309-3), returned without it; a
// bare LF does not end it (cocomm waits on, here until "<timeout>").
std::string read_line(int fd, int ms) {
  std::string got;
  char c = 0;
  pollfd p{fd, POLLIN, 0};
  while (::poll(&p, 1, ms) > 0 && ::recv(fd, &c, 1, 0) == 1) {
    got += c;
    if (got.size() >= 2 && got.compare(got.size() - 2, 2, "\r\n") == 0) return got.substr(0, got.size() - 2);
  }
  return got + "<timeout>";
}

// A gateway over one held bus (net 1) and one connected client; the test
// turns the server's loop itself.
struct HeldGateway {
  HeldGateway() {
    std::filesystem::remove_all(dir);
    EXPECT_FALSE(server.open_unix(dir / "ascii.sock"));
    fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    (dir / "ascii.sock").string().copy(addr.sun_path, sizeof addr.sun_path - 1);
    EXPECT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  }
  ~HeldGateway() {
    ::close(fd);
    server.close();
    std::filesystem::remove_all(dir);
  }
  void send(const std::string& text) const {
    ASSERT_EQ(::send(fd, text.data(), text.size(), 0), static_cast<ssize_t>(text.size()));
  }
  // Turns the loop until the bus holds `n` commands (at most 200 turns).
  bool run_until_held(std::size_t n) {
    for (int i = 0; i < 200 && bus.held() < n; ++i) {
      (void)server.process(std::chrono::steady_clock::now());
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return bus.held() == n;
  }
  // Turns the loop a few times (what the main thread does on its own).
  void turn(int times = 20) {
    for (int i = 0; i < times; ++i) {
      (void)server.process(std::chrono::steady_clock::now());
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }

  std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("cobridge-ascii-held-" + std::to_string(::getpid()));
  HeldCommands bus;
  AsciiServer server{bus, {}};
  int fd = -1;
};

// CiA 309-3 "[seq] net node r index sub type" -> "[seq] value", sent by the
// bus's thread (here the test's) while the main loop does not run.
TEST(AsciiServer, ReadAnswerReachesTheClientWithoutTheMainLoop) {
  HeldGateway g;
  g.send("[1] 1 20 r 0x1018 4 u32\n[2] 1 20 r 0x1018 1 u32\n");  // pipelined
  ASSERT_TRUE(g.run_until_held(1));
  RemoteResult r;
  r.data = {0xD1, 0x07, 0x00, 0x00};
  g.bus.finish(r);
  EXPECT_EQ(read_line(g.fd, 500), "[1] 2001");
  // The main loop learns it is done and takes the next line, in order.
  ASSERT_TRUE(g.run_until_held(1));
  r.data = {0x82, 0x01, 0x00, 0x00};
  g.bus.finish(r);
  EXPECT_EQ(read_line(g.fd, 500), "[2] 386");
}

// Issue 15: a read lends the connection to the bus thread
// (connection_loan.hpp), which takes another read on the same net itself,
// with the connection's default node, and nothing else; what it gives back
// is served by the main loop as if read there.
TEST(AsciiServer, AReadLendsTheConnectionForTheNextReadOnItsNet) {
  HeldGateway g;
  g.send("[1] set node 20\n");
  g.turn();
  EXPECT_EQ(read_line(g.fd, 500), "[1] OK");

  g.send("[3] r 0x1018 4 u32\n");
  ASSERT_TRUE(g.run_until_held(1));
  auto held = g.bus.take();
  ASSERT_TRUE(held && held->first.loan);
  const auto loan = held->first.loan;
  RemoteResult r;
  r.data = {0xD1, 0x07, 0x00, 0x00};
  r.kept = answer_client(held->first, r);
  ASSERT_TRUE(r.kept);
  push_result(*held->second, r, true);
  EXPECT_EQ(read_line(g.fd, 500), "[3] 2001");

  EXPECT_FALSE(loan->take("[4] 2 20 r 0x1018 1", *loan->connection));  // another net
  EXPECT_FALSE(loan->take("[4] 1 20 w 0x2000 0 u8 1", *loan->connection));
  EXPECT_FALSE(loan->take("[4] set node 5", *loan->connection));
  EXPECT_FALSE(loan->take("[4] 1 0 r 0x1018 1", *loan->connection));  // node 0: the main thread's error
  auto next = loan->take("[5] r 0x1018 1 u32", *loan->connection);
  ASSERT_TRUE(next);
  EXPECT_EQ(next->node, 20);  // the default node
  EXPECT_EQ(next->sub, 1);
  next->direct = loan->connection;
  RemoteResult one;
  one.data = {0x2A, 0, 0, 0};
  (void)answer_client(*next, one);
  EXPECT_EQ(read_line(g.fd, 500), "[5] 42");

  // While lent, the main loop does not read the client: the bus thread does.
  g.send("[6] info version\n");
  g.turn();
  EXPECT_EQ(read_line(g.fd, 100), "<timeout>");
  char buf[64];
  RemoteResult back;
  const ssize_t n = ::recv(loan->connection->fd(), buf, sizeof buf, MSG_DONTWAIT);
  ASSERT_EQ(n, 17);
  back.input.assign(buf, static_cast<std::size_t>(n));
  give_back(held->first.tag, *held->second, back);
  g.turn();
  EXPECT_EQ(read_line(g.fd, 500).rfind("[6] cobridge", 0), 0U);
}

// CiA 309-3 (answer syntax): every answer ends with CR LF, whoever sends it
// (the main loop, the bus thread, the main loop after the bus thread), the
// error answers of lines that are no request included; a request ended by
// CR LF is served as one ended by LF (issue 25, item 1: `cocomm` hung on
// every answer ended by a bare LF).
TEST(AsciiServer, EveryAnswerEndsWithCrLfAndCrLfRequestsAreServed) {
  HeldGateway g;
  g.send("[1] set node 20\r\n");
  g.turn();
  EXPECT_EQ(read_line(g.fd, 500), "[1] OK");
  g.send("garbage\r\n[2] 1 20 jump\n[3] 1 20 w 0x2000 0 i16 0x12345\r\n");
  g.turn();
  EXPECT_EQ(read_line(g.fd, 500), "[0] ERROR: 101");  // no sequence number
  EXPECT_EQ(read_line(g.fd, 500), "[2] ERROR: 100");
  EXPECT_EQ(read_line(g.fd, 500), "[3] ERROR: 101");  // the value does not fit i16
  g.send("[4] " + std::string(2000, 'x') + "\r\n[5] help\r\n");
  g.turn(40);
  EXPECT_EQ(read_line(g.fd, 500), "[0] ERROR: 101");  // longer than max_line
  EXPECT_EQ(read_line(g.fd, 500).rfind("[5] commands:", 0), 0U);

  // Answered by the bus thread (direct_answer.hpp).
  g.send("[6] r 0x1018 4 u32\r\n");
  ASSERT_TRUE(g.run_until_held(1));
  RemoteResult r;
  r.data = {0xD1, 0x07, 0x00, 0x00};
  g.bus.finish(r);
  EXPECT_EQ(read_line(g.fd, 500), "[6] 2001");
  g.turn();

  // Answered by the main loop (no connection for the bus thread to write to).
  g.send("[7] 1 20 r 0x1018 1 u32\r\n");
  ASSERT_TRUE(g.run_until_held(1));
  auto held = g.bus.take();
  ASSERT_TRUE(held);
  held->first.direct.reset();
  held->first.loan.reset();
  RemoteResult abort;
  abort.error = cobridge::Error(Errc::kFailed, "aborted");
  abort.abort_code = 0x06020000;
  hand_back(held->first, abort, held->second.get());
  g.turn();
  EXPECT_EQ(read_line(g.fd, 500), "[7] ERROR: 0x06020000");
}

// A connection beyond max_clients is told why before it is closed, in the
// same line shape.
TEST(AsciiServer, ARefusedConnectionsAnswerEndsWithCrLf) {
  const auto dir = std::filesystem::temp_directory_path() / ("cobridge-ascii-full-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  HeldCommands bus;
  AsciiServerOptions options;
  options.max_clients = 0;
  AsciiServer server(bus, options);
  ASSERT_FALSE(server.open_unix(dir / "ascii.sock"));
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  (dir / "ascii.sock").string().copy(addr.sun_path, sizeof addr.sun_path - 1);
  ASSERT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  for (int i = 0; i < 20 && server.clients() == 0; ++i) {
    std::vector<pollfd> fds;
    server.add_poll_fds(fds);
    (void)::poll(fds.data(), fds.size(), 10);
    server.note_ready(fds);
    (void)server.process(std::chrono::steady_clock::now());
  }
  EXPECT_EQ(read_line(fd, 500), "[0] ERROR: 102");
  ::close(fd);
  server.close();
  std::filesystem::remove_all(dir);
}

}  // namespace
