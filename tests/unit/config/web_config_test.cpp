// The [web] table (docs/web.md "Configuration"): defaults, every key, and
// every mistake reported at its file:line:column like the other sections.
#include "config/load.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

namespace fs = std::filesystem;
using cobridge::config::load;
using cobridge::config::to_string;
using ::testing::HasSubstr;

namespace {

const fs::path kFixtures = fs::path(__FILE__).parent_path() / "fixtures";

TEST(WebConfig, AbsentMeansNoWebService) {
  const auto r = load(kFixtures / "good_minimal.toml");
  ASSERT_TRUE(r.ok());
  EXPECT_FALSE(r.config().web.has_value());
}

TEST(WebConfig, EveryKey) {
  const auto r = load(kFixtures / "good_web.toml");
  std::string all;
  for (const auto& d : r.diagnostics()) all += to_string(d) + "\n";
  ASSERT_TRUE(r.ok()) << all;
  const auto& w = *r.config().web;
  EXPECT_TRUE(w.enabled);
  EXPECT_EQ(w.bind, "0.0.0.0");
  EXPECT_EQ(w.port, 9180);
  // Relative files are relative to the configuration file's directory.
  EXPECT_EQ(w.tls_cert, kFixtures / "certs/web.crt");
  EXPECT_EQ(w.tls_key, kFixtures / "certs/web.key");
  EXPECT_EQ(w.auth_file, "/etc/cobridge/web-users");
  EXPECT_EQ(w.max_clients, 8U);
  EXPECT_EQ(w.timeout_s, 5U);
  EXPECT_EQ(w.auth_file_at.line, 16U);
  // Canonical: lower case, no final dot, IPv6 without brackets as inet_ntop writes it.
  ASSERT_TRUE(w.hosts.has_value());
  EXPECT_EQ(*w.hosts, (std::vector<std::string>{"gw1.plant.local", "10.1.2.3", "2001:db8::1", "::1"}));
  EXPECT_EQ(w.hosts_at.line, 19U);
}

// Web.hosts absent is not web.hosts = [] (docs/web.md, "Host").
TEST(WebConfig, HostsAbsentIsNotHostsEmpty) {
  const std::string bus = "[[bus]]\nname = \"line1\"\ninterface = \"vcan0\"\n\n";
  const auto absent = cobridge::config::load_string(bus + "[web]\nbind = \"0.0.0.0\"\n", "absent.toml");
  ASSERT_TRUE(absent.ok());
  EXPECT_FALSE(absent.config().web->hosts.has_value());
  const auto empty = cobridge::config::load_string(bus + "[web]\nbind = \"0.0.0.0\"\nhosts = []\n", "empty.toml");
  ASSERT_TRUE(empty.ok());
  ASSERT_TRUE(empty.config().web->hosts.has_value());
  EXPECT_TRUE(empty.config().web->hosts->empty());
}

TEST(WebConfig, HostsMistakesAtTheirPlace) {
  const fs::path path = kFixtures / "bad_web_hosts.toml";
  const auto r = load(path);
  ASSERT_FALSE(r.ok());
  const auto& d = r.diagnostics();
  std::string all;
  for (const auto& x : d) all += to_string(x) + "\n";
  ASSERT_EQ(d.size(), 5U) << all;
  for (std::size_t i = 0; i < d.size(); ++i) {
    EXPECT_EQ(d[i].line, 9U + i) << all;
    EXPECT_THAT(d[i].message, HasSubstr("is not a host name or IP address")) << all;
  }
  EXPECT_THAT(d[0].message, HasSubstr("\"gw1.plant.local:8080\""));
  EXPECT_THAT(d[3].message, HasSubstr("(not a string)"));
}

TEST(WebConfig, MistakesAtTheirPlace) {
  const fs::path path = kFixtures / "bad_web.toml";
  const auto r = load(path);
  ASSERT_FALSE(r.ok());
  const auto& d = r.diagnostics();
  std::string all;
  for (const auto& x : d) all += to_string(x) + "\n";
  ASSERT_EQ(d.size(), 5U) << all;
  EXPECT_EQ(d[0].line, 11U);
  EXPECT_THAT(d[0].message, HasSubstr("web.bind \"localhost\" is not an IP address"));
  EXPECT_EQ(d[1].line, 12U);
  EXPECT_THAT(d[1].message, HasSubstr("web.port"));
  EXPECT_EQ(d[2].line, 13U);
  EXPECT_THAT(d[2].message, HasSubstr("web.tls_cert is set but web.tls_key is not"));
  EXPECT_EQ(d[3].line, 14U);
  EXPECT_THAT(d[3].message, HasSubstr("web.max_clients"));
  EXPECT_EQ(d[4].line, 15U);
  EXPECT_THAT(d[4].message, HasSubstr("colour"));
  for (const auto& x : d) EXPECT_EQ(x.file, path.string());
}

}  // namespace
