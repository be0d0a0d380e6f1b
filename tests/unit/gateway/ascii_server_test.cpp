// AsciiServer (gateway/remote/ascii_server.hpp): a gateway that cannot open
// says what failed where, in the one error shape (base/error.hpp), and the
// daemon keeps running without it.
#include "gateway/remote/ascii_server.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

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

}  // namespace
