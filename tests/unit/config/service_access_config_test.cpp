// [control] and [ascii_gateway] (docs/configuration.md):
// read-only unless writes_enabled, the gateway bound to 127.0.0.1 by default.
#include "config/load.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

using cobridge::config::load_string;

namespace {
const char* kBase = "[gateway]\nid = \"t\"\nstate_dir = \"/tmp/x\"\ncontrol_socket = \"/run/x/control.sock\"\n";
}

TEST(ServiceAccessConfig, DefaultsAreReadOnly) {
  const auto r = load_string(kBase, "t.toml", "/tmp");
  ASSERT_TRUE(r.ok());
  EXPECT_FALSE(r.config().services.control.writes_enabled);
  EXPECT_FALSE(r.config().services.ascii.enabled);
  EXPECT_FALSE(r.config().services.ascii.writes_enabled);
  EXPECT_EQ(r.config().services.ascii.bind, "127.0.0.1");
}

TEST(ServiceAccessConfig, SectionsAreRead) {
  const std::string text = std::string(kBase) +
                           "[control]\nwrites_enabled = true\nwrite_group = \"root\"\n"
                           "[ascii_gateway]\nsocket = \"/run/x/a.sock\"\ntcp_port = 5309\nwrites_enabled = true\n"
                           "write_group = \"root\"\nwrite_allow = [\"10.0.0.0/8\", \"127.0.0.1\"]\n";
  const auto r = load_string(text, "t.toml", "/tmp");
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r.config().services.control.writes_enabled);
  EXPECT_EQ(r.config().services.control.write_group, "root");
  EXPECT_TRUE(r.config().services.ascii.enabled);  // the section switches it on
  EXPECT_EQ(r.config().services.ascii.tcp_port, 5309);
  EXPECT_EQ(r.config().services.ascii.socket, "/run/x/a.sock");
  EXPECT_EQ(r.config().services.ascii.write_group, "root");
  EXPECT_EQ(r.config().services.ascii.write_allow, (std::vector<std::string>{"10.0.0.0/8", "127.0.0.1"}));
}

// The 309-3 write_allow entries are networks; a name is refused at its place.
TEST(ServiceAccessConfig, AsciiWriteAllowEntriesMustBeNetworks) {
  const std::string text = std::string(kBase) + "[ascii_gateway]\nwrite_allow = [\"10.0.0.0/8\", \"scada-host\"]\n";
  const auto r = load_string(text, "t.toml", "/tmp");
  ASSERT_FALSE(r.ok());
  ASSERT_EQ(r.diagnostics().size(), 1U);
  EXPECT_EQ(r.diagnostics()[0].line, 6U);
  EXPECT_NE(r.diagnostics()[0].message.find("\"scada-host\" is not an address or CIDR network"), std::string::npos);
}

TEST(ServiceAccessConfig, BadValuesAreReported) {
  const std::string text = std::string(kBase) + "[ascii_gateway]\nsocket = \"rel.sock\"\nbind = \"localhost\"\nport = 1\n";
  const auto r = load_string(text, "t.toml", "/tmp");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.diagnostics().size(), 3U);
}

// A write group that does not exist would refuse every
// write but root's without a word: with writes on it is an error at its line.
TEST(ServiceAccessConfig, AWriteGroupThatDoesNotExistIsAnErrorWhenWritesAreOn) {
  const std::string on = std::string(kBase) + "[control]\nwrites_enabled = true\nwrite_group = \"cbt-no-such-group\"\n";
  const auto r = load_string(on, "t.toml", "/tmp");
  ASSERT_FALSE(r.ok());
  ASSERT_EQ(r.diagnostics().size(), 1U);
  EXPECT_EQ(r.diagnostics()[0].line, 7U);
  EXPECT_NE(r.diagnostics()[0].message.find("control.write_group \"cbt-no-such-group\" is not a group on this machine"),
            std::string::npos)
      << r.diagnostics()[0].message;
  const std::string off = std::string(kBase) + "[control]\nwrite_group = \"cbt-no-such-group\"\n";
  EXPECT_TRUE(load_string(off, "t.toml", "/tmp").ok());
  const std::string anyone = std::string(kBase) + "[control]\nwrites_enabled = true\nwrite_group = \"\"\n";
  EXPECT_TRUE(load_string(anyone, "t.toml", "/tmp").ok());
}
