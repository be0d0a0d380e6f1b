// AsciiServer (gateway/remote/ascii_server.hpp): a gateway that cannot open
// says what failed where, in the one error shape (base/error.hpp), and the
// daemon keeps running without it; the answer to a CiA 309-3 read reaches
// the client from the thread that finished it (issue 15).
#include "gateway/remote/ascii_server.hpp"

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

// What a client reads within `ms`, without the server turning meanwhile.
std::string read_line(int fd, int ms) {
  std::string got;
  char c = 0;
  pollfd p{fd, POLLIN, 0};
  while (::poll(&p, 1, ms) > 0 && ::recv(fd, &c, 1, 0) == 1) {
    if (c == '\n') return got;
    got += c;
  }
  return got + "<timeout>";
}

// CiA 309-3 "[seq] net node r index sub type" -> "[seq] value", sent by the
// bus's thread (here the test's) while the main loop does not run.
TEST(AsciiServer, ReadAnswerReachesTheClientWithoutTheMainLoop) {
  const auto dir = std::filesystem::temp_directory_path() / ("cobridge-ascii-direct-" + std::to_string(::getpid()));
  HeldCommands bus;
  AsciiServer server(bus, {});
  ASSERT_FALSE(server.open_unix(dir / "ascii.sock"));
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  (dir / "ascii.sock").string().copy(addr.sun_path, sizeof addr.sun_path - 1);
  ASSERT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  auto run_until_held = [&](std::size_t n) {
    for (int i = 0; i < 200 && bus.held() < n; ++i) {
      (void)server.process(std::chrono::steady_clock::now());
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return bus.held() == n;
  };
  const std::string first = "[1] 1 20 r 0x1018 4 u32\n[2] 1 20 r 0x1018 1 u32\n";  // pipelined
  ASSERT_EQ(::send(fd, first.data(), first.size(), 0), static_cast<ssize_t>(first.size()));
  ASSERT_TRUE(run_until_held(1));
  RemoteResult r;
  r.data = {0xD1, 0x07, 0x00, 0x00};
  bus.finish(r);
  EXPECT_EQ(read_line(fd, 500), "[1] 2001");
  // The main loop learns it is done and takes the next line, in order.
  ASSERT_TRUE(run_until_held(1));
  r.data = {0x82, 0x01, 0x00, 0x00};
  bus.finish(r);
  EXPECT_EQ(read_line(fd, 500), "[2] 386");
  ::close(fd);
  server.close();
  std::filesystem::remove_all(dir);
}

}  // namespace
