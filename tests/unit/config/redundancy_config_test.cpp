// The [redundancy] table (docs/configuration.md "[redundancy]"): absent or
// off changes nothing; hot-standby needs the gateway's own node-ID, which no
// device and no node pool may use; every mistake at its line.
#include "config/load.hpp"
#include "unit/config/one_bus_config.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

using cobridge::config::load_string;

namespace {

const std::string& kBase = cobridge::config::test::kOneBus;

std::string all(const cobridge::config::LoadResult& r) { return cobridge::config::test::all_diagnostics(r); }

TEST(RedundancyConfig, AbsentOrOffMeansTheOnlyMaster) {
  auto r = load_string(kBase, "t.toml", "/tmp");
  ASSERT_TRUE(r.ok()) << all(r);
  EXPECT_FALSE(r.config().redundancy.has_value());
  r = load_string(kBase + "[redundancy]\nmode = \"off\"\nnode_id = 5\n", "t.toml", "/tmp");
  ASSERT_TRUE(r.ok()) << all(r);
  EXPECT_FALSE(r.config().redundancy.has_value());
}

TEST(RedundancyConfig, EveryKey) {
  const auto r = load_string(kBase +
                                 "[redundancy]\nmode = \"hot-standby\"\nnode_id = 126\npriority = 1\n"
                                 "heartbeat_ms = 50\npreempt = true\nhold_s = 30\n",
                             "t.toml", "/tmp");
  ASSERT_TRUE(r.ok()) << all(r);
  const auto& s = *r.config().redundancy;
  EXPECT_EQ(s.node_id, 126);
  EXPECT_EQ(s.priority, 1);
  EXPECT_EQ(s.heartbeat, std::chrono::milliseconds(50));
  EXPECT_TRUE(s.preempt);
  EXPECT_EQ(s.hold, std::chrono::seconds(30));
}

TEST(RedundancyConfig, DefaultsAreTheDocumentedOnes) {
  const auto r = load_string(kBase + "[redundancy]\nmode = \"hot-standby\"\nnode_id = 126\n", "t.toml", "/tmp");
  ASSERT_TRUE(r.ok()) << all(r);
  const auto& s = *r.config().redundancy;
  EXPECT_EQ(s.priority, 0);
  EXPECT_EQ(s.heartbeat, std::chrono::milliseconds(100));
  EXPECT_FALSE(s.preempt);
  EXPECT_EQ(s.hold, std::chrono::seconds(10));
}

TEST(RedundancyConfig, MistakesAreReportedAtTheirLine) {
  // kBase has 8 lines; [redundancy] is line 9.
  auto r = load_string(kBase + "[redundancy]\nnode_id = 5\n", "t.toml", "/tmp");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(all(r).find("needs mode"), std::string::npos) << all(r);
  r = load_string(kBase + "[redundancy]\nmode = \"hot-standby\"\n", "t.toml", "/tmp");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(all(r).find("needs node_id"), std::string::npos) << all(r);
  r = load_string(kBase + "[redundancy]\nmode = \"warm\"\nnode_id = 5\npriority = 3\nheartbeat_ms = 5\nspeed = 1\n",
                  "t.toml", "/tmp");
  ASSERT_FALSE(r.ok());
  const std::string text = all(r);
  EXPECT_NE(text.find("10: redundancy.mode \"warm\" is not allowed"), std::string::npos) << text;
  EXPECT_NE(text.find("speed"), std::string::npos) << text;
}

TEST(RedundancyConfig, TheGatewaysNodeIdIsNoDevicesAndInNoPool) {
  const std::string device =
      "[[device]]\nname = \"enc\"\nbus = \"line1\"\nserial = 1\nmodel = \"MC1-2800\"\nnode_id = 7\n";
  auto r = load_string(kBase + device + "[redundancy]\nmode = \"hot-standby\"\nnode_id = 7\n", "t.toml", "/tmp");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(all(r).find("redundancy.node_id 7 is device \"enc\"'s node-ID"), std::string::npos) << all(r);
  r = load_string(kBase + "[redundancy]\nmode = \"hot-standby\"\nnode_id = 41\n", "t.toml", "/tmp");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(all(r).find("redundancy.node_id 41 is in bus \"line1\"'s node_pool"), std::string::npos) << all(r);
  // The default pool (1..127, nothing written) simply leaves it out.
  const std::string no_pool =
      "[gateway]\nid = \"t\"\nstate_dir = \"/tmp/x\"\ncontrol_socket = \"/run/x/control.sock\"\n"
      "[[bus]]\nname = \"line1\"\ninterface = \"vcan0\"\n[redundancy]\nmode = \"hot-standby\"\nnode_id = 120\n";
  r = load_string(no_pool, "t.toml", "/tmp");
  ASSERT_TRUE(r.ok()) << all(r);
  const auto& pool = r.config().buses[0].node_pool;
  EXPECT_EQ(pool.size(), 126U);
  EXPECT_EQ(std::count(pool.begin(), pool.end(), 120), 0);
}

}  // namespace
