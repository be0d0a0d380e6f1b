// [control] and [ascii_gateway] (issue 15, items 2-4; docs/configuration.md):
// read-only unless writes_enabled, the gateway bound to 127.0.0.1 by default.
#include "config/load.hpp"

#include <gtest/gtest.h>

using cobridge::config::load_string;

namespace {
const char* kBase = "[gateway]\nid = \"t\"\nstate_dir = \"/tmp/x\"\ncontrol_socket = \"/run/x/control.sock\"\n";
}

TEST(RemoteAccessConfig, DefaultsAreReadOnly) {
  const auto r = load_string(kBase, "t.toml", "/tmp");
  ASSERT_TRUE(r.ok());
  EXPECT_FALSE(r.config().remote.control.writes_enabled);
  EXPECT_FALSE(r.config().remote.ascii.enabled);
  EXPECT_FALSE(r.config().remote.ascii.writes_enabled);
  EXPECT_EQ(r.config().remote.ascii.bind, "127.0.0.1");
}

TEST(RemoteAccessConfig, SectionsAreRead) {
  const std::string text = std::string(kBase) +
                           "[control]\nwrites_enabled = true\nwrite_group = \"ops\"\n"
                           "[ascii_gateway]\nsocket = \"/run/x/a.sock\"\ntcp_port = 5309\nwrites_enabled = true\n";
  const auto r = load_string(text, "t.toml", "/tmp");
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r.config().remote.control.writes_enabled);
  EXPECT_EQ(r.config().remote.control.write_group, "ops");
  EXPECT_TRUE(r.config().remote.ascii.enabled);  // the section switches it on
  EXPECT_EQ(r.config().remote.ascii.tcp_port, 5309);
  EXPECT_EQ(r.config().remote.ascii.socket, "/run/x/a.sock");
}

TEST(RemoteAccessConfig, BadValuesAreReported) {
  const std::string text = std::string(kBase) + "[ascii_gateway]\nsocket = \"rel.sock\"\nbind = \"localhost\"\nport = 1\n";
  const auto r = load_string(text, "t.toml", "/tmp");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.diagnostics().size(), 3U);
}
