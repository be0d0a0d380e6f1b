// Configuration of the Modbus output (docs/modbus.md "Configuration").
#include "server_config.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>

#include <gtest/gtest.h>

namespace cobridge::modbus {
namespace {

// docs/modbus.md "Configuration".
TEST(ModbusConfig, DefaultsWhenEmpty) {
  ServerConfig c;
  ASSERT_TRUE(parse_config("", c).ok());
  EXPECT_EQ(c.bind, "127.0.0.1");  // loopback, as web and 309-3
  EXPECT_EQ(c.port, 1502);
  EXPECT_EQ(c.max_clients, 32u);
  EXPECT_EQ(c.idle_timeout_s, 60u);
  EXPECT_EQ(c.unit_id, -1);
  EXPECT_EQ(c.word_order, WordOrder::kBig);
  EXPECT_FALSE(c.writes_enabled);
  EXPECT_FALSE(c.offline_exception);
  EXPECT_TRUE(c.allow.empty());
}

// docs/modbus.md "Configuration".
TEST(ModbusConfig, AllKeysParse) {
  ServerConfig c;
  const auto r = parse_config(R"(
bind = "127.0.0.1"
port = 15020
max_clients = 8
allow = ["10.0.0.0/8", "192.168.1.7", "fd00::/8"]
idle_timeout_s = 5
unit_id = 1
word_order = "little"
writes_enabled = true
offline_exception = true
max_devices = 100
)",
                              c);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(c.port, 15020);
  EXPECT_EQ(c.max_clients, 8u);
  EXPECT_EQ(c.unit_id, 1);
  EXPECT_EQ(c.word_order, WordOrder::kLittle);
  EXPECT_TRUE(c.writes_enabled);
  EXPECT_TRUE(c.offline_exception);
  EXPECT_EQ(c.max_devices, 100);
  EXPECT_TRUE(c.allow.contains_v4(0x0A010203));   // 10.1.2.3
  EXPECT_TRUE(c.allow.contains_v4(0xC0A80107));   // 192.168.1.7
  EXPECT_FALSE(c.allow.contains_v4(0xC0A80108));  // 192.168.1.8
  EXPECT_FALSE(c.allow.contains_v4(0x0B000001));  // 11.0.0.1
}

// docs/modbus.md "Configuration".
TEST(ModbusConfig, UnknownKeyIsRejectedByName) {
  ServerConfig c;
  const auto r = parse_config("port = 1502\nmax_client = 4\n", c);
  EXPECT_EQ(r.code, ConfigErrc::kUnknownKey);
  EXPECT_NE(r.message.find("'max_client'"), std::string::npos) << r.message;
}

// docs/modbus.md "Configuration".
TEST(ModbusConfig, BadValuesAreRejected) {
  ServerConfig c;
  EXPECT_EQ(parse_config("word_order = \"middle\"", c).code, ConfigErrc::kBadValue);
  EXPECT_EQ(parse_config("port = 70000", c).code, ConfigErrc::kBadValue);
  EXPECT_EQ(parse_config("port = \"502\"", c).code, ConfigErrc::kBadType);
  EXPECT_EQ(parse_config("allow = [\"10.0.0.0/33\"]", c).code, ConfigErrc::kBadValue);
  EXPECT_EQ(parse_config("allow = [\"example.com\"]", c).code, ConfigErrc::kBadValue);
  const auto w = parse_config("write_allow = [\"10.1.0.0/16\", \"scada\"]", c);
  EXPECT_EQ(w.code, ConfigErrc::kBadValue);
  EXPECT_EQ(w.message, "config: 'write_allow' entry \"scada\" is not an address or CIDR network");
  EXPECT_EQ(parse_config("bind = \"localhost\"", c).code, ConfigErrc::kBadValue);
  EXPECT_EQ(parse_config("max_devices = 0", c).code, ConfigErrc::kBadValue);
  EXPECT_EQ(parse_config("unit_id = 256", c).code, ConfigErrc::kBadValue);
  EXPECT_EQ(parse_config("port = ", c).code, ConfigErrc::kSyntax);
}

// write_allow is its own list; empty allows every client's writes.
TEST(ModbusConfig, WriteAllowIsParsedApartFromAllow) {
  ServerConfig c;
  ASSERT_TRUE(parse_config("allow = [\"10.0.0.0/8\"]\nwrite_allow = [\"10.1.2.3\"]", c).ok());
  sockaddr_in in{};
  in.sin_family = AF_INET;
  ASSERT_EQ(inet_pton(AF_INET, "10.9.9.9", &in.sin_addr), 1);
  EXPECT_TRUE(c.allow.contains(reinterpret_cast<const sockaddr*>(&in)));
  EXPECT_FALSE(c.write_allow.contains(reinterpret_cast<const sockaddr*>(&in)));
  ASSERT_EQ(inet_pton(AF_INET, "10.1.2.3", &in.sin_addr), 1);
  EXPECT_TRUE(c.write_allow.contains(reinterpret_cast<const sockaddr*>(&in)));
  ServerConfig d;
  ASSERT_TRUE(parse_config("", d).ok());
  EXPECT_TRUE(d.write_allow.empty());
}

// IPv4 clients on a dual-stack socket arrive as ::ffff:a.b.c.d (RFC 4291 §2.5.5.2).
TEST(ModbusConfig, AllowListMatchesV4MappedAddresses) {
  cobridge::IpAllowList a;
  ASSERT_TRUE(a.add("127.0.0.0/8"));
  sockaddr_in6 in6{};
  in6.sin6_family = AF_INET6;
  ASSERT_EQ(inet_pton(AF_INET6, "::ffff:127.0.0.1", &in6.sin6_addr), 1);
  EXPECT_TRUE(a.contains(reinterpret_cast<const sockaddr*>(&in6)));
  ASSERT_EQ(inet_pton(AF_INET6, "::ffff:10.0.0.1", &in6.sin6_addr), 1);
  EXPECT_FALSE(a.contains(reinterpret_cast<const sockaddr*>(&in6)));
  ASSERT_EQ(inet_pton(AF_INET6, "::1", &in6.sin6_addr), 1);
  EXPECT_FALSE(a.contains(reinterpret_cast<const sockaddr*>(&in6)));
}

// A client on the loopback address (127.0.0.0/8, ::1,
// ::ffff:127.x) writes only when write_allow is not empty and holds it: any
// account of the gateway's host reaches 127.0.0.1, around write_group.
// Other clients: as contains(), an empty list takes everyone.
TEST(ModbusConfig, LoopbackWritersOnlyWhenWriteAllowListsThem) {
  // As accept() fills them: a sockaddr_storage of either family.
  auto v4 = [](const char* text) {
    sockaddr_storage ss{};
    auto* in = reinterpret_cast<sockaddr_in*>(&ss);
    in->sin_family = AF_INET;
    EXPECT_EQ(inet_pton(AF_INET, text, &in->sin_addr), 1);
    return ss;
  };
  auto v6 = [](const char* text) {
    sockaddr_storage ss{};
    auto* in6 = reinterpret_cast<sockaddr_in6*>(&ss);
    in6->sin6_family = AF_INET6;
    EXPECT_EQ(inet_pton(AF_INET6, text, &in6->sin6_addr), 1);
    return ss;
  };
  const sockaddr_storage local = v4("127.0.0.1"), other_local = v4("127.1.2.3"), remote = v4("10.1.2.50");
  const sockaddr_storage local6 = v6("::1"), mapped = v6("::ffff:127.0.0.1"), remote6 = v6("fd00::5");
  auto sa = [](const auto& a) { return reinterpret_cast<const sockaddr*>(&a); };
  cobridge::IpAllowList empty;
  EXPECT_FALSE(empty.allows_writer(sa(local)));
  EXPECT_FALSE(empty.allows_writer(sa(other_local)));
  EXPECT_FALSE(empty.allows_writer(sa(local6)));
  EXPECT_FALSE(empty.allows_writer(sa(mapped)));
  EXPECT_FALSE(empty.allows_writer_v4(0x7F000001u));
  EXPECT_TRUE(empty.allows_writer(sa(remote)));
  EXPECT_TRUE(empty.allows_writer(sa(remote6)));
  EXPECT_TRUE(empty.allows_writer_v4(0x0A010232u));
  EXPECT_TRUE(empty.contains(sa(local)));  // reading is not writing
  cobridge::IpAllowList listed;
  ASSERT_TRUE(listed.add("127.0.0.1/32"));
  EXPECT_TRUE(listed.allows_writer(sa(local)));
  EXPECT_TRUE(listed.allows_writer(sa(mapped)));
  EXPECT_TRUE(listed.allows_writer_v4(0x7F000001u));
  EXPECT_FALSE(listed.allows_writer(sa(other_local)));
  EXPECT_FALSE(listed.allows_writer(sa(local6)));
  EXPECT_FALSE(listed.allows_writer(sa(remote)));
  EXPECT_TRUE(cobridge::IpAllowList::is_loopback(sa(local6)));
  EXPECT_FALSE(cobridge::IpAllowList::is_loopback(sa(remote6)));
}

}  // namespace
}  // namespace cobridge::modbus
