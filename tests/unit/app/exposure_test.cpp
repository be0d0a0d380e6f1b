// app/exposure: every door a configuration opens to the
// network is a warning at the line that opens it, in --check-config, at
// start and on reload; loopback listeners and allow-listed writes are quiet.
#include "app/exposure.hpp"

#include "app/validation.hpp"
#include "config/load.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace {

namespace fs = std::filesystem;
using cobridge::app::exposure_warnings;
using cobridge::app::is_loopback;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

const char* kBase = "[gateway]\nid = \"t\"\nstate_dir = \"/tmp/x\"\ncontrol_socket = \"/run/x/control.sock\"\n";

std::vector<std::string> warnings_of(const std::string& rest) {
  const auto r = cobridge::config::load_string(std::string(kBase) + rest, "plant.toml", "/tmp");
  EXPECT_TRUE(r.ok());
  return r.ok() ? exposure_warnings(r.config()) : std::vector<std::string>{};
}

TEST(Exposure, LoopbackIsQuiet) {
  EXPECT_TRUE(is_loopback("127.0.0.1"));
  EXPECT_TRUE(is_loopback("127.1.2.3"));
  EXPECT_TRUE(is_loopback("::1"));
  EXPECT_FALSE(is_loopback("0.0.0.0"));
  EXPECT_FALSE(is_loopback("::"));
  EXPECT_FALSE(is_loopback("10.1.2.3"));
  EXPECT_THAT(warnings_of("[web]\n[ascii_gateway]\ntcp_port = 60000\n[outputs.modbus]\nbind = \"127.0.0.1\"\n"),
              IsEmpty());
}

// Any account of the gateway's host reaches a loopback
// listener, so a TCP client on 127.0.0.1 or ::1 writes only when write_allow
// lists the loopback address (IpAllowList::allows_writer). Both sides of
// that choice are said: writes enabled on a loopback listener nobody may
// write to, and a write_allow that takes local writers (around write_group).
TEST(Exposure, LoopbackWritersAreAnExplicitChoiceAndSaidSo) {
  const std::string modbus = "[outputs.modbus]\nbind = \"127.0.0.1\"\nwrites_enabled = true\n";
  EXPECT_THAT(warnings_of(modbus), ElementsAre(HasSubstr("plant.toml:5:1: [outputs.modbus] listens on 127.0.0.1 with "
                                                         "writes_enabled on the loopback address, and write_allow "
                                                         "does not list it: every write is refused")));
  EXPECT_THAT(warnings_of(modbus + "write_allow = [\"127.0.0.1/32\"]\n"),
              ElementsAre(HasSubstr("takes writes from this host's loopback address (write_allow lists it): every "
                                    "local account writes to the devices, around write_group")));
  EXPECT_THAT(warnings_of(modbus + "write_allow = [\"::1\"]\n"), ElementsAre(HasSubstr("around write_group")));
  const std::string ascii = "[ascii_gateway]\ntcp_port = 60000\nwrites_enabled = true\nwrite_group = \"\"\n";
  EXPECT_THAT(warnings_of(ascii), ElementsAre(HasSubstr("[ascii_gateway] listens on 127.0.0.1:60000 with "
                                                        "writes_enabled on the loopback address")));
  EXPECT_THAT(warnings_of(ascii + "write_allow = [\"127.0.0.0/8\"]\n"), ElementsAre(HasSubstr("around write_group")));
  // A network listener whose write_allow holds everything takes local writers too.
  EXPECT_THAT(warnings_of("[outputs.modbus]\nbind = \"0.0.0.0\"\nwrites_enabled = true\n"
                          "write_allow = [\"0.0.0.0/0\"]\n"),
              ElementsAre(HasSubstr("around write_group"), HasSubstr("(non-loopback) without authentication")));
  EXPECT_THAT(warnings_of("[outputs.modbus]\nbind = \"0.0.0.0\"\nwrites_enabled = true\n"
                          "write_allow = [\"10.1.2.50/32\"]\n"),
              ElementsAre(HasSubstr("(non-loopback) without authentication")));
}

TEST(Exposure, AWebPageOnTheNetworkWithoutTlsOrPasswordsIsNamedAtItsSection) {
  EXPECT_THAT(warnings_of("\n[web]\nbind = \"0.0.0.0\"\n"),
              ElementsAre(HasSubstr("plant.toml:6:1: [web] serves 0.0.0.0:8080 on a non-loopback address without TLS"),
                          HasSubstr("plant.toml:6:1: [web] serves 0.0.0.0:8080 on a non-loopback address without "
                                    "authentication"),
                          HasSubstr("plant.toml:6:1: web.bind \"0.0.0.0\" without web.hosts")));
  // Named hosts close the DNS-rebinding door (RFC 9110 §7.2 Host).
  EXPECT_THAT(warnings_of("\n[web]\nbind = \"0.0.0.0\"\nhosts = [\"gw1.plant.local\"]\n"),
              ElementsAre(HasSubstr("without TLS"), HasSubstr("without authentication")));
}

TEST(Exposure, The309TcpListenerOnTheNetworkAndItsWritesWithoutAnAllowList) {
  const std::string on = "[ascii_gateway]\ntcp_port = 60000\nbind = \"0.0.0.0\"\nwrites_enabled = true\n"
                         "write_group = \"\"\n";
  EXPECT_THAT(warnings_of(on), ElementsAre(HasSubstr("plant.toml:5:1: [ascii_gateway] listens on 0.0.0.0:60000 "
                                                     "(non-loopback); CiA 309-3 has no authentication"),
                                           HasSubstr("with writes_enabled and no write_allow")));
  EXPECT_THAT(warnings_of(on + "write_allow = [\"10.1.2.50\"]\n"), ElementsAre(HasSubstr("no authentication")));
}

TEST(Exposure, AnOutputBoundToTheNetworkAndItsWritesWithoutWriteAllow) {
  const std::string modbus = "[outputs.modbus]\nbind = \"0.0.0.0\"\nwrites_enabled = true\n";
  EXPECT_THAT(warnings_of(modbus),
              ElementsAre(HasSubstr("plant.toml:5:1: [outputs.modbus] listens on 0.0.0.0 (non-loopback) without "
                                    "authentication"),
                          HasSubstr("with writes_enabled and no write_allow")));
  EXPECT_THAT(warnings_of(modbus + "write_allow = [\"10.1.2.50/32\"]\n"), ElementsAre(HasSubstr("listens on")));
  EXPECT_THAT(warnings_of("[outputs.modbus]\nbind = \"0.0.0.0\"\nenabled = false\n"), IsEmpty());
}

TEST(Exposure, ATlsKeyOthersCanReadIsNamedAtItsKey) {
  const fs::path dir = fs::temp_directory_path() / ("cobridge-exposure-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "key.pem") << "-----BEGIN PRIVATE KEY-----\n";
  std::ofstream(dir / "cert.pem") << "-----BEGIN CERTIFICATE-----\n";
  ::chmod((dir / "key.pem").c_str(), 0640);
  const std::string web = "[web]\ntls_cert = \"" + (dir / "cert.pem").string() + "\"\ntls_key = \"" +
                          (dir / "key.pem").string() + "\"\n";
  EXPECT_THAT(warnings_of(web), ElementsAre(HasSubstr("plant.toml:7:11: web.tls_key " + (dir / "key.pem").string() +
                                                      " is readable or writable by group or others (mode 0640)")));
  ::chmod((dir / "key.pem").c_str(), 0600);
  EXPECT_THAT(warnings_of(web), IsEmpty());
  fs::remove_all(dir);
}

// The same warnings reach --check-config, the start and every reload: validate().
TEST(Exposure, ValidationCarriesTheWarnings) {
  const fs::path file = fs::temp_directory_path() / ("cobridge-exposure-" + std::to_string(::getpid()) + ".toml");
  std::ofstream(file) << kBase << "[outputs.modbus]\nbind = \"0.0.0.0\"\n";
  const auto v = cobridge::app::validate(file);
  fs::remove(file);
  ASSERT_TRUE(v.config.has_value());
  EXPECT_THAT(v.warnings, ElementsAre(HasSubstr(file.string() + ":5:1: [outputs.modbus] listens on 0.0.0.0")));
}

}  // namespace
