// Host names in one canonical form: web.hosts and the
// host of a request's Host header field (RFC 9110 §7.2) compare equal when
// they name the same host.
#include "config/host_name.hpp"

#include <gtest/gtest.h>

#include <string>

using cobridge::config::canonical_host;
using cobridge::config::is_loopback_address;
using cobridge::config::is_wildcard_address;

namespace {

TEST(HostName, NamesAreLowerCaseWithoutTheFinalDot) {
  EXPECT_EQ(canonical_host("gw1.plant.local"), "gw1.plant.local");
  EXPECT_EQ(canonical_host("GW1.Plant.Local."), "gw1.plant.local");
  EXPECT_EQ(canonical_host("localhost"), "localhost");
  EXPECT_EQ(canonical_host("LOCALHOST."), "localhost");
  EXPECT_EQ(canonical_host("my_host-2"), "my_host-2");
  EXPECT_EQ(canonical_host("xn--bcher-kva.example"), "xn--bcher-kva.example");
  EXPECT_EQ(canonical_host(std::string(63, 'a') + ".b"), std::string(63, 'a') + ".b");
}

TEST(HostName, AddressesAreAsInetNtopWritesThem) {
  EXPECT_EQ(canonical_host("10.1.2.3"), "10.1.2.3");
  EXPECT_EQ(canonical_host("::1"), "::1");
  EXPECT_EQ(canonical_host("[::1]"), "::1");
  EXPECT_EQ(canonical_host("[2001:DB8:0:0::1]"), "2001:db8::1");
  EXPECT_EQ(canonical_host("0:0:0:0:0:0:0:1"), "::1");
  EXPECT_EQ(canonical_host("[::ffff:127.0.0.1]"), "::ffff:127.0.0.1");
}

TEST(HostName, AnythingElseIsNoHost) {
  for (const char* bad : {"", ".", "..", "a..b", ".a", "gw1:8080", "[::1]:8080", "http://gw1", "gw1/x", "user@gw1",
                          "gw 1", "gw1\t", "[10.1.2.3]", "[gw1]", "[::1", "::1]", "[fe80::1%25eth0]", "fe80::1%eth0",
                          "10.1.2", "127.1", "1.2.3.4.5", "h\xc3\xa9.example", "*.plant.local"})
    EXPECT_EQ(canonical_host(bad), std::nullopt) << bad;
  EXPECT_EQ(canonical_host(std::string(64, 'a') + ".b"), std::nullopt) << "a label of 64 bytes";
  std::string long_name;
  while (long_name.size() < 254) long_name += "abcdefghi.";
  EXPECT_EQ(canonical_host(long_name.substr(0, 254) + "x"), std::nullopt) << "over 253 bytes";
}

TEST(HostName, LoopbackAndWildcard) {
  for (const char* a : {"127.0.0.1", "127.1.2.3", "::1", "::ffff:127.0.0.1"}) EXPECT_TRUE(is_loopback_address(a)) << a;
  for (const char* a : {"10.1.2.3", "::", "0.0.0.0", "::ffff:10.0.0.1", "localhost", ""})
    EXPECT_FALSE(is_loopback_address(a)) << a;
  EXPECT_TRUE(is_wildcard_address("0.0.0.0"));
  EXPECT_TRUE(is_wildcard_address("::"));
  EXPECT_FALSE(is_wildcard_address("127.0.0.1"));
}

}  // namespace
