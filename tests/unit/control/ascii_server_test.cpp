// AsciiServer (control/ascii/ascii_server.hpp): a gateway that cannot open
// says what failed where, in the one error shape (base/error.hpp), and the
// daemon keeps running without it; a CiA 309-3 request's answer is written
// by the thread that owns the connection (the server's), in the order of the
// requests, with the request's sequence number.
#include "control/ascii/ascii_server.hpp"

#include "held_commands.hpp"

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
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

namespace bus = cobridge::bus;

namespace {

using cobridge::Errc;
using namespace cobridge::control;

class NoBuses final : public bus::ServiceTarget {
 public:
  [[nodiscard]] std::vector<bus::ServiceBus> buses() const override { return {}; }
  [[nodiscard]] cobridge::Error submit(std::string_view, bus::ServiceRequest, std::shared_ptr<bus::ServiceReplies>) override {
    return cobridge::Error(Errc::kNotFound, "no bus");
  }
  [[nodiscard]] std::optional<cobridge::config::ServiceAccess> access() const override { return std::nullopt; }
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

using cobridge::control::testing::HeldCommands;

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

// CiA 309-3 "[seq] net node r index sub type" -> "[seq] value". A finished
// command's result alone writes nothing (the bus thread never touches the
// client's socket); the server's turn writes it, then takes the next
// pipelined line, in order.
TEST(AsciiServer, ReadAnswerIsWrittenByTheServersTurnInOrder) {
  HeldGateway g;
  g.send("[1] 1 20 r 0x1018 4 u32\n[2] 1 20 r 0x1018 1 u32\n");  // pipelined
  ASSERT_TRUE(g.run_until_held(1));
  bus::ServiceResult r;
  r.data = {0xD1, 0x07, 0x00, 0x00};
  ASSERT_TRUE(g.bus.finish(r));
  EXPECT_EQ(read_line(g.fd, 100), "<timeout>") << "the answer was written by a thread other than the owner";
  g.turn();
  EXPECT_EQ(read_line(g.fd, 500), "[1] 2001");
  ASSERT_TRUE(g.run_until_held(1));
  r.data = {0x82, 0x01, 0x00, 0x00};
  ASSERT_TRUE(g.bus.finish(r));
  g.turn();
  EXPECT_EQ(read_line(g.fd, 500), "[2] 386");
}

// A read takes the connection's defaults ("set node"), its answer carries
// its own sequence number, and a request sent while it runs waits its turn
// (one request of a connection at a time), then is served with its own.
TEST(AsciiServer, AReadUsesTheConnectionsDefaultsAndLaterLinesWaitTheirTurn) {
  HeldGateway g;
  g.send("[1] set node 20\n");
  g.turn();
  EXPECT_EQ(read_line(g.fd, 500), "[1] OK");

  g.send("[3] r 0x1018 4 u32\n");
  ASSERT_TRUE(g.run_until_held(1));
  const auto cmd = g.bus.oldest();
  ASSERT_TRUE(cmd);
  EXPECT_EQ(cmd->node, 20);  // the default node
  EXPECT_EQ(cmd->sub, 4);
  g.send("[6] info version\n");
  g.turn();
  EXPECT_EQ(read_line(g.fd, 100), "<timeout>") << "a line was answered before the read it follows";
  bus::ServiceResult r;
  r.data = {0xD1, 0x07, 0x00, 0x00};
  ASSERT_TRUE(g.bus.finish(r));
  g.turn();
  EXPECT_EQ(read_line(g.fd, 500), "[3] 2001");
  EXPECT_EQ(read_line(g.fd, 500).rfind("[6] cobridge", 0), 0U);
}

// CiA 309-3 (answer syntax): every answer ends with CR LF, whoever sends it
// (a local answer, a bus command's result, a device's abort), the
// error answers of lines that are no request included; a request ended by
// CR LF is served as one ended by LF (`cocomm` hangs on
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

  // A bus command's result.
  g.send("[6] r 0x1018 4 u32\r\n");
  ASSERT_TRUE(g.run_until_held(1));
  bus::ServiceResult r;
  r.data = {0xD1, 0x07, 0x00, 0x00};
  ASSERT_TRUE(g.bus.finish(r));
  g.turn();
  EXPECT_EQ(read_line(g.fd, 500), "[6] 2001");

  // A device's abort.
  g.send("[7] 1 20 r 0x1018 1 u32\r\n");
  ASSERT_TRUE(g.run_until_held(1));
  bus::ServiceResult abort;
  abort.error = cobridge::Error(Errc::kFailed, "aborted");
  abort.abort_code = 0x06020000;
  ASSERT_TRUE(g.bus.finish(abort));
  g.turn();
  EXPECT_EQ(read_line(g.fd, 500), "[7] ERROR: 0x06020000");
}

// Any account of the gateway's host reaches 127.0.0.1,
// around the Unix socket's write_group, so a TCP client on the loopback
// address writes only when write_allow lists it; with an empty write_allow
// ("every client") its write is refused (CiA 309-3 ERROR: 100) and never
// reaches the bus, while a listed one's goes to the bus.
TEST(AsciiServer, ALoopbackTcpClientWritesOnlyWhenWriteAllowListsIt) {
  for (const bool listed : {false, true}) {
    SCOPED_TRACE(listed ? "write_allow = [127.0.0.1/32]" : "write_allow = []");
    HeldCommands bus;
    AsciiServerOptions options;
    options.writes_enabled = true;
    if (listed) {
      ASSERT_TRUE(options.write_allow.add("127.0.0.1/32"));
    }
    AsciiServer server(bus, options);
    std::uint16_t port = 0;
    for (int i = 0; i < 50 && port == 0; ++i) {
      const auto p = static_cast<std::uint16_t>(42000 + (::getpid() * 31 + i * 7919) % 20000);
      if (!server.open_tcp("127.0.0.1", p)) port = p;
    }
    ASSERT_NE(port, 0);
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(port);
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    const std::string write = "[1] 1 20 w 0x1017 0 u16 100\n";
    ASSERT_EQ(::send(fd, write.data(), write.size(), 0), static_cast<ssize_t>(write.size()));
    std::string answer = "<none>";
    for (int i = 0; i < 200 && bus.held() == 0; ++i) {
      (void)server.process(std::chrono::steady_clock::now());
      if (!listed && (answer = read_line(fd, 5)) != "<timeout>") break;
    }
    if (listed) {
      EXPECT_EQ(bus.held(), 1u) << "a listed loopback client's write did not reach the bus";
    } else {
      EXPECT_EQ(answer, "[1] ERROR: 100");
      EXPECT_EQ(bus.held(), 0u) << "a refused write reached the bus";
    }
    ::close(fd);
    server.close();
  }
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
