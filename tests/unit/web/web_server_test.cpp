// The web service (docs/web.md): routing, answers, authentication, the
// status snapshot shared by all clients, and the same requests over a real
// socket through libmicrohttpd (bad requests get 4xx and change nothing).
#include "web/web_server.hpp"

#include "web/http_route.hpp"
#include "web/metrics.hpp"
#include "web/status_page.hpp"
#include "http_client.hpp"
#include "web_fixture.hpp"

#include <arpa/inet.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>

using namespace std::chrono_literals;
using cobridge::Errc;
using cobridge::Error;
using cobridge::web::AuthFile;
using cobridge::web::Credentials;
using cobridge::web::Resource;
using cobridge::web::route_request;
using cobridge::web::WebServer;
using ::testing::HasSubstr;
using ::testing::Not;

namespace {

TEST(HttpRoute, ReadOnlyResources) {
  EXPECT_EQ(route_request("GET", "/").resource, Resource::page);
  EXPECT_EQ(route_request("GET", "/index.html").resource, Resource::page);
  EXPECT_EQ(route_request("GET", "/api/v1/status").resource, Resource::status_json);
  EXPECT_EQ(route_request("GET", "/metrics").resource, Resource::metrics);
  const auto head = route_request("HEAD", "/metrics");
  EXPECT_EQ(head.resource, Resource::metrics);
  EXPECT_TRUE(head.head);
  for (const char* m : {"POST", "PUT", "DELETE", "PATCH", "OPTIONS", "TRACE", "CONNECT", "get", ""})
    EXPECT_EQ(route_request(m, "/metrics").status, 405U) << m;
  EXPECT_EQ(route_request("GET", "/api/v1/status/").status, 404U);
  EXPECT_EQ(route_request("GET", "/../etc/passwd").status, 404U);
  EXPECT_EQ(route_request("GET", std::string(300, '/')).status, 414U);
}

TEST(WebServer, StatusIsTheControlSocketsJson) {
  const auto report = cobridge::web::test::sample_report(1, 2);
  WebServer server([&] { return report; });
  const auto a = server.handle("GET", "/api/v1/status", nullptr);
  EXPECT_EQ(a.status, 200U);
  EXPECT_STREQ(a.content_type, "application/json");
  EXPECT_EQ(a.body, cobridge::control::to_json(report) + "\n");  // one schema, one writer
  EXPECT_THAT(a.body, HasSubstr("\"emcy_history\":[{\"code\":20480,\"text\":\"hardware fault\""));
  EXPECT_THAT(a.body, HasSubstr("\"values\":{\"position\":1234,\"position_eng\":12.500,\"unit\":\"deg\",\"speed\":-3"));
  // Each output's own figures (Modbus clients connected).
  EXPECT_THAT(a.body, HasSubstr("\"outputs\":[{\"instance\":\"modbus\",\"type\":\"modbus\",\"running\":true,"
                                "\"figures\":{\"modbus_clients_connected\":3,\"modbus_requests\":1200}}"));
}

TEST(WebServer, PageIsServedFromTheBinaryWithoutExternalFetches) {
  WebServer server([] { return cobridge::control::StatusReport{}; });
  const auto a = server.handle("GET", "/", nullptr);
  EXPECT_EQ(a.status, 200U);
  EXPECT_THAT(std::string(a.content_type), HasSubstr("text/html"));
  EXPECT_EQ(a.body, cobridge::web::status_page_html());
  EXPECT_THAT(a.body, HasSubstr("api/v1/status"));
  // No URL but the SVG namespace name (an identifier, never fetched).
  std::string rest = a.body;
  for (std::size_t at; (at = rest.find("http://www.w3.org/2000/svg")) != std::string::npos;) rest.erase(at, 26);
  EXPECT_THAT(rest, Not(HasSubstr("http://")));
  EXPECT_THAT(rest, Not(HasSubstr("https://")));
  EXPECT_THAT(rest, Not(HasSubstr("\"//"))) << "a protocol-relative URL?";
  EXPECT_THAT(a.body, Not(HasSubstr("<link")));
  EXPECT_THAT(a.body, Not(HasSubstr("src=")));
}

TEST(WebServer, ManyClientsShareOneSnapshot) {
  std::atomic<int> calls{0};
  WebServer server([&] {
    ++calls;
    return cobridge::web::test::sample_report(1, 1);
  }, 10s);
  for (int i = 0; i < 100; ++i) {
    (void)server.handle("GET", "/metrics", nullptr);
    (void)server.handle("GET", "/api/v1/status", nullptr);
  }
  EXPECT_EQ(calls.load(), 1);
}

TEST(WebServer, BadRequestsGet4xxAndAskNothingOfTheDaemon) {
  std::atomic<int> calls{0};
  WebServer server([&] {
    ++calls;
    return cobridge::control::StatusReport{};
  });
  EXPECT_EQ(server.handle("POST", "/api/v1/status", nullptr).status, 405U);
  EXPECT_EQ(server.handle("DELETE", "/metrics", nullptr).status, 405U);
  EXPECT_EQ(server.handle("GET", "/api/v2/commission", nullptr).status, 404U);
  EXPECT_EQ(calls.load(), 0);
}

class AuthTest : public ::testing::Test {
 protected:
  void SetUp() override {
    file_ = std::filesystem::temp_directory_path() / ("cobridge-web-users-" + std::to_string(::getpid()));
    std::ofstream(file_) << "# operators\nalice:" << cobridge::web::test::kAliceHash << "\nbob:"
                         << cobridge::web::test::kBobHash << "\n";
    ::chmod(file_.c_str(), 0600);
  }
  void TearDown() override { std::filesystem::remove(file_); }
  std::filesystem::path file_;
};

TEST_F(AuthTest, BasicAuthenticationFromAFileOnlyItsOwnerReads) {
  AuthFile auth;
  const Error loaded = auth.load(file_);
  ASSERT_FALSE(loaded) << loaded.to_string();
  EXPECT_EQ(auth.users(), 2U);
  EXPECT_TRUE(auth.check("alice", "s3cret"));
  EXPECT_TRUE(auth.check("bob", "hunter:2"));  // the first colon separates
  EXPECT_FALSE(auth.check("alice", "s3cre"));
  EXPECT_FALSE(auth.check("alice", "s3cret!"));
  EXPECT_FALSE(auth.check("", ""));

  WebServer server([] { return cobridge::control::StatusReport{}; });
  server.set_auth(auth);
  auto now = std::chrono::steady_clock::now();
  server.set_clock([&] { return now; });
  const auto none = server.handle("GET", "/metrics", nullptr);
  EXPECT_EQ(none.status, 401U);
  EXPECT_TRUE(none.ask_credentials);
  const Credentials right{"alice", "s3cret"};
  EXPECT_EQ(server.handle("GET", "/metrics", &right).status, 200U) << "no credentials sent is no failed login";
  const Credentials wrong{"alice", "nope"};
  EXPECT_EQ(server.handle("GET", "/metrics", &wrong).status, 401U);
  // Then the right password too waits out the window (RFC 6585 §4).
  const auto backoff = server.handle("GET", "/metrics", &right);
  EXPECT_EQ(backoff.status, 429U);
  EXPECT_EQ(backoff.retry_after_s, 1);
  EXPECT_FALSE(backoff.ask_credentials);
  now += 1s;
  EXPECT_EQ(server.handle("GET", "/metrics", &right).status, 200U);

  ::chmod(file_.c_str(), 0640);
  const Error refused = auth.load(file_);
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused.kind, Errc::kInvalidArgument);
  EXPECT_EQ(refused.where, file_.string());
  EXPECT_THAT(refused.message, HasSubstr("chmod 600"));
}

// The [web] files' problems are the project's Error, placed at the
// key that names the file (where "file:line:col: web.<key>", then the file),
// so --check-config and the daemon print them like every other error.
TEST_F(AuthTest, WebSettingsProblemsAreErrorsAtTheirKey) {
  ::chmod(file_.c_str(), 0640);
  cobridge::config::WebSettings s;
  s.tls_cert = "/nonexistent-dir/web.crt";
  s.tls_key = file_;  // not PEM
  s.auth_file = file_;
  s.tls_cert_at = {"cobridge.toml", 40, 1};
  s.tls_key_at = {"cobridge.toml", 41, 1};
  s.auth_file_at = {"cobridge.toml", 42, 1};
  const std::vector<Error> errors = cobridge::web::check_web_settings(s);
  ASSERT_GE(errors.size(), 3U);
  EXPECT_EQ(errors[0].kind, Errc::kNotFound);
  EXPECT_EQ(errors[0].where, "cobridge.toml:40:1: web.tls_cert");
  EXPECT_EQ(errors[0].message, "cannot read /nonexistent-dir/web.crt");
  EXPECT_EQ(errors[1].kind, Errc::kInvalidArgument);
  EXPECT_EQ(errors[1].where, "cobridge.toml:41:1: web.tls_key");
  EXPECT_THAT(errors[1].message, HasSubstr("is not a PEM file"));
  const Error& auth = errors.back();
  EXPECT_EQ(auth.kind, Errc::kInvalidArgument);
  EXPECT_EQ(auth.where, "cobridge.toml:42:1: web.auth_file: " + file_.string());
  EXPECT_THAT(auth.message, HasSubstr("chmod 600"));

  WebServer server([] { return cobridge::control::StatusReport{}; });
  const Error refused = server.start(s);
  EXPECT_EQ(refused.where, errors[0].where) << "start() refuses with the first problem";
  EXPECT_FALSE(server.running());
}

// ---- over a socket -----------------------------------------------------------

using cobridge::web::test::http_exchange;

TEST(WebServerSocket, AnswersOverHttpAndRefusesWhatItShould) {
  std::atomic<int> calls{0};
  WebServer server([&] {
    ++calls;
    return cobridge::web::test::sample_report(1, 2);
  });
  cobridge::config::WebSettings s;
  s.port = 0;  // the kernel's choice
  const Error started = server.start(s);
  ASSERT_FALSE(started) << started.to_string();
  const std::uint16_t port = server.port();
  ASSERT_NE(port, 0);

  const auto status = http_exchange(port, "GET /api/v1/status HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n");
  EXPECT_THAT(status, HasSubstr("HTTP/1.1 200"));
  EXPECT_THAT(status, HasSubstr("Content-Type: application/json"));
  EXPECT_THAT(status, HasSubstr("\"gateway\":\"gw-1\""));

  const auto head = http_exchange(port, "HEAD /metrics HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n");
  EXPECT_THAT(head, HasSubstr("HTTP/1.1 200"));
  EXPECT_THAT(head, Not(HasSubstr("# HELP")));

  const auto post = http_exchange(port, "POST /api/v1/status HTTP/1.1\r\nHost: localhost\r\nContent-Length: 5\r\n"
                                   "Connection: close\r\n\r\nhello");
  EXPECT_THAT(post, HasSubstr("HTTP/1.1 405"));
  EXPECT_THAT(post, HasSubstr("Allow: GET, HEAD"));

  EXPECT_THAT(http_exchange(port, "GET /nothing HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n"), HasSubstr("HTTP/1.1 404"));
  // Not HTTP: libmicrohttpd closes the connection without an answer, or says 400.
  const auto garbage = http_exchange(port, "garbage\r\n\r\n");
  EXPECT_TRUE(garbage.empty() || garbage.find("HTTP/1.1 400") == 0) << garbage;
  // A request header bigger than the per-connection memory limit.
  const std::string big = "GET / HTTP/1.1\r\nHost: localhost\r\nX-Big: " + std::string(64 * 1024, 'a') + "\r\n\r\n";
  EXPECT_THAT(http_exchange(port, big), HasSubstr("HTTP/1.1 431"));

  EXPECT_EQ(calls.load(), 1);  // only the one GET of the status asked the daemon
  server.stop();
}

// A request's bytes for a failure message: control bytes as \xNN.
std::string printable(const std::string& bytes) {
  std::string out;
  for (const char ch : bytes) {
    const auto u = static_cast<unsigned char>(ch);
    if (u >= 0x20 && u < 0x7F) {
      out += ch;
    } else {
      const char* hex = "0123456789abcdef";
      out += std::string("\\x") + hex[u >> 4] + hex[u & 15];
    }
  }
  return out;
}

// libmicrohttpd hands the request target on as a C string,
// so "GET /metrics\0x" would be answered 200 with the metrics (the path cut at
// the NUL), and so would "/metrics%00x" (cut at the decoded NUL). A target holding
// a NUL, another control byte or a space, sent or percent-encoded, gets 400,
// and the daemon is not asked for anything.
TEST(WebServerSocket, ATargetWithAControlByteOrASpaceGets400) {
  std::atomic<int> calls{0};
  WebServer server([&] {
    ++calls;
    return cobridge::web::test::sample_report(1, 2);
  });
  cobridge::config::WebSettings s;
  s.port = 0;
  const Error started = server.start(s);
  ASSERT_FALSE(started) << started.to_string();
  const std::string tail = " HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n";
  const std::string targets[] = {std::string("/metrics\0x", 10), std::string("/metrics\0", 9),
                                 std::string("/\0/metrics", 10), "/metrics\x01", "/metrics\tx", "/metrics\rx",
                                 "/metrics\x1f", "/metrics\x7f", "/metrics x", "/metrics?a b", "/metrics%00x",
                                 "/metrics%0a", "/metrics%1F", "/metrics%7f", "/metrics?x=%00"};
  for (const std::string& target : targets) {
    for (const char* method : {"GET ", "HEAD "}) {
      const std::string answer = http_exchange(server.port(), method + target + tail);
      const std::string status_line = answer.substr(0, answer.find('\r'));
      EXPECT_EQ(status_line.rfind("HTTP/1.1 400 ", 0), 0u) << method << printable(target) << " -> " << status_line;
      EXPECT_EQ(answer.find("# HELP"), std::string::npos) << method << printable(target) << ": the metrics";
    }
  }
  EXPECT_EQ(calls.load(), 0) << "no refused request asked the daemon for its status";
  // The same requests without the bad byte are served.
  const std::string metrics = http_exchange(server.port(), "GET /metrics?x=%41" + tail);
  EXPECT_EQ(metrics.rfind("HTTP/1.1 200 ", 0), 0u) << metrics;
  EXPECT_THAT(metrics, HasSubstr("# HELP"));
  server.stop();
}

}  // namespace
