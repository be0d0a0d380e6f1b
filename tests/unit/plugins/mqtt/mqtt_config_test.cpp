// [outputs.mqtt] parsing (docs/mqtt.md "Configuration"): defaults, every
// refusal names its key and reason, the password only from a 0600 file.
#include "mqtt_config.hpp"

#include <cobridge/plugin.h>

#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

namespace cobridge::mqtt {
namespace {

using plugin::ConfigErrc;

std::string temp_file(const std::string& text, mode_t mode) {
  char path[] = "/tmp/cobridge-mqtt-test-XXXXXX";
  const int fd = ::mkstemp(path);
  EXPECT_GE(fd, 0);
  ::close(fd);
  std::ofstream(path) << text;
  ::chmod(path, mode);
  return path;
}

plugin::Error parse(const std::string& text, MqttConfig& c) { return parse_config(text, "gw-1", c); }

TEST(MqttConfig, Defaults) {
  MqttConfig c;
  ASSERT_FALSE(parse("", c));
  EXPECT_EQ(c.host, "127.0.0.1");
  EXPECT_EQ(c.port, 1883);
  EXPECT_EQ(c.group_id, "cobridge");
  EXPECT_EQ(c.edge_node_id, "gw-1");  // the gateway id
  EXPECT_EQ(c.client_id, "cobridge-gw-1");
  EXPECT_EQ(c.keepalive_s, 30u);
  EXPECT_FALSE(c.tls());
  EXPECT_TRUE(c.primary_host_id.empty());
  EXPECT_EQ(c.bdseq_file, "/var/lib/cobridge/mqtt-gw-1.bdseq");
  EXPECT_EQ(c.store_seconds, 30u);
  EXPECT_FALSE(c.writes.enabled);  // DCMD refused unless asked for
  EXPECT_TRUE(c.writes.allow.empty());
}

TEST(MqttConfig, PlaintextBrokerOutsideLoopbackWarned) {
  EXPECT_TRUE(is_loopback_host("127.0.0.1"));
  EXPECT_TRUE(is_loopback_host("127.1.2.3"));
  EXPECT_TRUE(is_loopback_host("localhost"));
  EXPECT_TRUE(is_loopback_host("::1"));
  EXPECT_FALSE(is_loopback_host("127.example.com"));
  EXPECT_FALSE(is_loopback_host("10.0.0.5"));
  EXPECT_FALSE(is_loopback_host("broker.plant"));
  MqttConfig c;
  ASSERT_FALSE(parse("host = \"10.0.0.5\"\n", c));
  const std::string w = plaintext_warning(c);
  EXPECT_NE(w.find("'host' = \"10.0.0.5\""), std::string::npos) << w;
  EXPECT_NE(w.find("plaintext"), std::string::npos);
  MqttConfig local;
  ASSERT_FALSE(parse("", local));
  EXPECT_EQ(plaintext_warning(local), "");
}

TEST(MqttConfig, GoodWriteAllow) {
  MqttConfig c;
  const plugin::Error e =
      parse("writes_enabled = true\nwrite_allow = [\"rot\", \"mt:preset\", \"*:store\"]\n", c);
  ASSERT_FALSE(e) << e.message;
  EXPECT_TRUE(c.writes.enabled);
  ASSERT_EQ(c.writes.allow.size(), 3u);
  EXPECT_EQ(c.writes.allow[1].device, "mt");
  EXPECT_EQ(c.writes.allow[1].kind, COBRIDGE_COMMAND_PRESET);
  EXPECT_EQ(c.writes.allow[2].device, "*");
  EXPECT_EQ(c.writes.allow[2].kind, COBRIDGE_COMMAND_STORE);
}

TEST(MqttConfig, GoodFullTable) {
  const std::string pw = temp_file("s3cret\n", 0600);
  MqttConfig c;
  const plugin::Error e = parse("host = \"broker\"\nport = 8883\nclient_id = \"c\"\ngroup_id = \"g\"\n"
                                "edge_node_id = \"e\"\nkeepalive_s = 10\nusername = \"u\"\npassword_file = \"" +
                                    pw + "\"\nprimary_host_id = \"scada\"\n[deadband]\nPosition = 4\nSpeed = 0.5\n",
                                c);
  ASSERT_FALSE(e) << e.message;
  EXPECT_EQ(c.password, "s3cret");
  EXPECT_EQ(c.primary_host_id, "scada");
  EXPECT_EQ(c.deadband[0], 4.0);
  EXPECT_EQ(c.deadband[2], 0.5);
  ::unlink(pw.c_str());
}

TEST(MqttConfig, BadPasswordFileOpenToOthersRefused) {
  const std::string pw = temp_file("x\n", 0644);
  MqttConfig c;
  const plugin::Error e = parse("username = \"u\"\npassword_file = \"" + pw + "\"\n", c);
  ASSERT_TRUE(e);
  EXPECT_EQ(e.code, make_error_code(ConfigErrc::kBadFile));
  EXPECT_NE(e.message.find("'password_file'"), std::string::npos) << e.message;
  EXPECT_NE(e.message.find("0644"), std::string::npos) << e.message;
  ::unlink(pw.c_str());
}

TEST(MqttConfig, BadPlainPasswordRefused) {
  MqttConfig c;
  const plugin::Error e = parse("username = \"u\"\npassword = \"x\"\n", c);
  ASSERT_TRUE(e);
  EXPECT_NE(e.message.find("password_file"), std::string::npos) << e.message;
}

struct BadCase {
  const char* toml;
  ConfigErrc code;
  const char* key;
};

// Per device (or "*", every device not named) the process metrics it publishes.
TEST(MqttConfig, MetricSetsPerDeviceWithADefault) {
  MqttConfig c;
  ASSERT_FALSE(parse_config("[metrics]\n\"*\" = [\"Position\", \"Stale\"]\nrot-a = [\"Speed\"]\n", "gw", c));
  const std::uint32_t position = 1u << process_index(DeviceMetric::kPosition);
  const std::uint32_t stale = 1u << process_index(DeviceMetric::kStale);
  const std::uint32_t speed = 1u << process_index(DeviceMetric::kSpeed);
  EXPECT_EQ(c.metrics.for_device("rot-a"), speed);
  EXPECT_EQ(c.metrics.for_device("mt-b"), position | stale);
  MqttConfig none;
  ASSERT_FALSE(parse_config("[metrics]\nrot-a = [\"Speed\"]\n", "gw", none));
  EXPECT_EQ(none.metrics.for_device("mt-b"), MetricSets::kAll);  // no "*": every metric
}

TEST(MqttConfig, BadValuesNameTheirKey) {
  const BadCase cases[] = {
      {"hots = \"x\"\n", ConfigErrc::kUnknownKey, "'hots'"},
      {"port = 0\n", ConfigErrc::kOutOfRange, "'port'"},
      {"port = \"1883\"\n", ConfigErrc::kWrongType, "'port'"},
      {"keepalive_s = 2\n", ConfigErrc::kOutOfRange, "'keepalive_s'"},
      {"group_id = \"a/b\"\n", ConfigErrc::kOutOfRange, "'group_id'"},
      {"edge_node_id = \"e#\"\n", ConfigErrc::kOutOfRange, "'edge_node_id'"},
      {"password_file = \"/nonexistent\"\n", ConfigErrc::kMissingKey, "'username'"},
      {"username = \"u\"\npassword_file = \"/nonexistent\"\n", ConfigErrc::kBadFile, "'password_file'"},
      {"ca_file = \"/nonexistent/ca.pem\"\n", ConfigErrc::kBadFile, "'ca_file'"},
      {"[deadband]\nPositon = 1\n", ConfigErrc::kUnknownKey, "'deadband.Positon'"},
      {"[deadband]\nPosition = -1\n", ConfigErrc::kOutOfRange, "'deadband.Position'"},
      {"metrics = [\"Position\"]\n", ConfigErrc::kWrongType, "'metrics'"},
      {"[metrics]\nrot = \"Position\"\n", ConfigErrc::kWrongType, "'metrics.rot'"},
      {"[metrics]\nrot = []\n", ConfigErrc::kWrongType, "'metrics.rot'"},
      {"[metrics]\nrot = [\"Position\", \"Posiiton\"]\n", ConfigErrc::kUnknownKey, "'metrics.rot[1]'"},
      {"[metrics]\n\"*\" = [1]\n", ConfigErrc::kWrongType, "'metrics.*[0]'"},
      {"host = \n", ConfigErrc::kSyntax, "config:"},
      {"writes_enabled = 1\n", ConfigErrc::kWrongType, "'writes_enabled'"},
      {"bdseq_file = \"/nonexistent/dir/b\"\n", ConfigErrc::kBadFile, "'bdseq_file'"},
      {"store_seconds = -1\n", ConfigErrc::kOutOfRange, "'store_seconds'"},
      {"store_rate = 0\n", ConfigErrc::kOutOfRange, "'store_rate'"},
      {"write_allow = \"rot\"\n", ConfigErrc::kWrongType, "'write_allow'"},
      {"write_allow = [\"rot:reboot\"]\n", ConfigErrc::kOutOfRange, "'write_allow[0]'"},
      {"write_allow = [\"rot\", 3]\n", ConfigErrc::kWrongType, "'write_allow[1]'"},
      {"write_allow = [\":store\"]\n", ConfigErrc::kOutOfRange, "'write_allow[0]'"},
      {"write_allow = [\"*\"]\n", ConfigErrc::kOutOfRange, "'write_allow[0]'"},
  };
  for (const BadCase& bc : cases) {
    MqttConfig c;
    const plugin::Error e = parse(bc.toml, c);
    ASSERT_TRUE(e) << bc.toml;
    EXPECT_EQ(e.code, make_error_code(bc.code)) << bc.toml << " -> " << e.message;
    EXPECT_NE(e.message.find(bc.key), std::string::npos) << e.message;
  }
}

TEST(MqttConfig, BadTlsHalfPairRefused) {
  const std::string cert = temp_file("pem", 0644);
  MqttConfig c;
  plugin::Error e = parse("ca_file = \"" + cert + "\"\ncert_file = \"" + cert + "\"\n", c);
  ASSERT_TRUE(e);
  EXPECT_NE(e.message.find("'key_file'"), std::string::npos) << e.message;
  e = parse("cert_file = \"" + cert + "\"\nkey_file = \"" + cert + "\"\n", c);
  ASSERT_TRUE(e);
  EXPECT_NE(e.message.find("'ca_file'"), std::string::npos) << e.message;
  ::unlink(cert.c_str());
}

}  // namespace
}  // namespace cobridge::mqtt
