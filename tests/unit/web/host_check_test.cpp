// The Host check (DNS rebinding): RFC 9110 §7.2 (Host
// names the origin server), §15.5.20 (421 Misdirected Request for a request
// this server does not answer for), RFC 9112 §3.2 (400 for a Host that is
// not uri-host[:port], or more than one).
#include "web/host_check.hpp"

#include "web/peer_address.hpp"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>

#include <string>

using cobridge::config::WebSettings;
using cobridge::web::HostCheck;
using cobridge::web::HostField;
using cobridge::web::parse_host_field;
using Verdict = HostCheck::Verdict;

namespace {

WebSettings bound_to(const std::string& bind) {
  WebSettings s;
  s.bind = bind;
  return s;
}

WebSettings with_hosts(const std::string& bind, std::vector<std::string> hosts) {
  WebSettings s = bound_to(bind);
  s.hosts = std::move(hosts);
  return s;
}

Verdict judge(const HostCheck& c, const char* host, const std::string& local) {
  return c.check(parse_host_field(host, host != nullptr ? 1 : 0, false), local);
}

// RFC 9110 §7.2: Host = uri-host [ ":" port ]; compared without the port.
TEST(HostField, Rfc9110Sec7_2_HostWithoutPortCanonical) {
  EXPECT_EQ(parse_host_field("gw1.plant.local", 1).host, "gw1.plant.local");
  EXPECT_EQ(parse_host_field("GW1.Plant.Local.:8080", 1).host, "gw1.plant.local");
  EXPECT_EQ(parse_host_field("10.1.2.3:80", 1).host, "10.1.2.3");
  EXPECT_EQ(parse_host_field("[::1]:8080", 1).host, "::1");
  EXPECT_EQ(parse_host_field("[::1]", 1).host, "::1");
  EXPECT_EQ(parse_host_field("localhost:", 1).host, "localhost") << "port = *DIGIT may be empty";
  EXPECT_EQ(parse_host_field(nullptr, 0, false).kind, HostField::Kind::absent) << "HTTP/1.0";
}

// RFC 9112 §3.2: "A server MUST respond with a 400 (Bad Request) ... to any
// request message that contains more than one Host header field line or a
// Host header field with an invalid field value."
TEST(HostField, Rfc9112Sec3_2_InvalidOrRepeatedHostIsABadRequest) {
  for (const char* bad : {"", ":8080", "gw1:http", "gw1:80:80", "::1", "::1:8080", "[::1]x", "[::1]:8o", "[::1",
                          "user@gw1", "gw1/x", "gw 1", "http://gw1", "[10.1.2.3]", "gw1\r", "*"})
    EXPECT_EQ(parse_host_field(bad, 1).kind, HostField::Kind::invalid) << bad;
  EXPECT_EQ(parse_host_field("gw1.plant.local", 2).kind, HostField::Kind::invalid) << "two Host lines";
  EXPECT_EQ(parse_host_field(nullptr, 0).kind, HostField::Kind::invalid) << "HTTP/1.1 without Host";
  const HostCheck any;
  EXPECT_EQ(any.check(parse_host_field("gw1", 2), "127.0.0.1"), Verdict::bad_request);
  EXPECT_EQ(judge(any, "gw1:http", "127.0.0.1"), Verdict::bad_request);
}

// Bound to the loopback, without hosts: its address and the loopback names,
// nothing else (a rebinding page's own name gets 421, RFC 9110 §15.5.20).
TEST(HostCheck, Rfc9110Sec15_5_20_LoopbackBindAnswersOnlyLoopbackNames) {
  const HostCheck c(bound_to("127.0.0.1"));
  EXPECT_FALSE(c.accepts_any());
  for (const char* ok : {"127.0.0.1", "127.0.0.1:8080", "localhost", "LOCALHOST:8080", "localhost.", "[::1]:8080"})
    EXPECT_EQ(judge(c, ok, "127.0.0.1"), Verdict::ok) << ok;
  for (const char* foreign : {"evil.example", "evil.example:8080", "gw1.plant.local", "10.1.2.3", "127.0.0.2",
                              "localhost.evil.example", "x"})
    EXPECT_EQ(judge(c, foreign, "127.0.0.1"), Verdict::misdirected) << foreign;
  EXPECT_EQ(judge(c, nullptr, "127.0.0.1"), Verdict::ok) << "HTTP/1.0 without Host: not a browser's";
}

TEST(HostCheck, ASpecificBindAnswersItsAddressAndItsHosts) {
  const HostCheck plain(bound_to("10.1.2.3"));
  EXPECT_EQ(judge(plain, "10.1.2.3:8080", "10.1.2.3"), Verdict::ok);
  EXPECT_EQ(judge(plain, "10.1.2.3", ""), Verdict::ok) << "the bind, when the local address is unknown";
  EXPECT_EQ(judge(plain, "gw1.plant.local", "10.1.2.3"), Verdict::misdirected);
  EXPECT_EQ(judge(plain, "localhost", "10.1.2.3"), Verdict::misdirected) << "not reachable on the loopback";

  const HostCheck named(with_hosts("10.1.2.3", {"gw1.plant.local"}));
  EXPECT_EQ(judge(named, "GW1.plant.local:8080", "10.1.2.3"), Verdict::ok);
  EXPECT_EQ(judge(named, "10.1.2.3", "10.1.2.3"), Verdict::ok);
  EXPECT_EQ(judge(named, "gw2.plant.local", "10.1.2.3"), Verdict::misdirected);

  const HostCheck v6(bound_to("2001:DB8::1"));
  EXPECT_EQ(judge(v6, "[2001:db8:0::1]:8080", "2001:db8::1"), Verdict::ok);
  EXPECT_EQ(judge(v6, "[2001:db8::2]", "2001:db8::1"), Verdict::misdirected);
}

// A wildcard bind without hosts cannot know its names: any Host, and a warning.
TEST(HostCheck, AWildcardBindWithoutHostsAcceptsAnyHostAndWarns) {
  for (const char* bind : {"0.0.0.0", "::"}) {
    const HostCheck c(bound_to(bind));
    EXPECT_TRUE(c.accepts_any()) << bind;
    EXPECT_EQ(judge(c, "evil.example", "10.1.2.3"), Verdict::ok) << bind;
    EXPECT_EQ(judge(c, "a b", "10.1.2.3"), Verdict::bad_request) << bind << ": still a bad request";
    const std::string warning = cobridge::web::host_check_warning(bound_to(bind));
    EXPECT_NE(warning.find("DNS rebinding"), std::string::npos) << warning;
    EXPECT_NE(warning.find("web.hosts"), std::string::npos) << warning;
  }
  for (const WebSettings& quiet : {bound_to("127.0.0.1"), bound_to("10.1.2.3"), with_hosts("0.0.0.0", {})})
    EXPECT_EQ(cobridge::web::host_check_warning(quiet), "") << quiet.bind;
  WebSettings off = bound_to("0.0.0.0");
  off.enabled = false;
  EXPECT_EQ(cobridge::web::host_check_warning(off), "");
}

// With hosts, a wildcard bind answers those names, the address each
// connection arrived at, and the loopback names on a loopback connection.
TEST(HostCheck, AWildcardBindWithHostsAnswersThoseAndTheArrivalAddress) {
  const HostCheck c(with_hosts("0.0.0.0", {"gw1.plant.local", "10.9.9.9"}));
  EXPECT_FALSE(c.accepts_any());
  EXPECT_EQ(judge(c, "gw1.plant.local", "10.1.2.3"), Verdict::ok);
  EXPECT_EQ(judge(c, "10.9.9.9", "10.1.2.3"), Verdict::ok) << "a listed address (e.g. the NAT's)";
  EXPECT_EQ(judge(c, "10.1.2.3:8080", "10.1.2.3"), Verdict::ok) << "the address the client reached";
  EXPECT_EQ(judge(c, "localhost:8080", "127.0.0.1"), Verdict::ok);
  EXPECT_EQ(judge(c, "localhost", "10.1.2.3"), Verdict::misdirected);
  EXPECT_EQ(judge(c, "0.0.0.0", "10.1.2.3"), Verdict::misdirected) << "the wildcard is no host's name";
  EXPECT_EQ(judge(c, "evil.example", "10.1.2.3"), Verdict::misdirected);
  // hosts = []: IP addresses (and localhost) only.
  const HostCheck none(with_hosts("::", {}));
  EXPECT_EQ(judge(none, "[2001:db8::5]", "2001:db8::5"), Verdict::ok);
  EXPECT_EQ(judge(none, "gw1.plant.local", "2001:db8::5"), Verdict::misdirected);
}

TEST(PeerAddress, TextAndThrottleKey) {
  sockaddr_in v4{};
  v4.sin_family = AF_INET;
  ::inet_pton(AF_INET, "192.0.2.7", &v4.sin_addr);
  const auto* a4 = reinterpret_cast<const sockaddr*>(&v4);
  EXPECT_EQ(cobridge::web::address_text(a4), "192.0.2.7");
  EXPECT_EQ(cobridge::web::throttle_key(a4), "192.0.2.7");

  sockaddr_in6 v6{};
  v6.sin6_family = AF_INET6;
  ::inet_pton(AF_INET6, "2001:db8:1:2:aaaa:bbbb:cccc:dddd", &v6.sin6_addr);
  const auto* a6 = reinterpret_cast<const sockaddr*>(&v6);
  EXPECT_EQ(cobridge::web::address_text(a6), "2001:db8:1:2:aaaa:bbbb:cccc:dddd");
  EXPECT_EQ(cobridge::web::throttle_key(a6), "2001:db8:1:2::/64") << "one IPv6 host picks from a /64";

  ::inet_pton(AF_INET6, "::ffff:192.0.2.7", &v6.sin6_addr);
  EXPECT_EQ(cobridge::web::address_text(a6), "192.0.2.7");
  EXPECT_EQ(cobridge::web::throttle_key(a6), "192.0.2.7");
  EXPECT_EQ(cobridge::web::address_text(nullptr), "");
}

}  // namespace
