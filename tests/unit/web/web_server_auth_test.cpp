// Web access control over a real socket: a WebServer on the loopback, raw
// HTTP requests. The Host check (RFC 9110 §7.2; 421 Misdirected Request,
// RFC 9110 §15.5.20; 400 for a bad Host, RFC 9112 §3.2) and failed logins:
// 401, then 429 Too Many Requests with Retry-After (RFC 6585 §4) for that
// client only, and one warning line naming the client and the user, never
// the password.
#include "sys/logging.hpp"
#include "web/web_server.hpp"

#include "http_client.hpp"
#include "web_fixture.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

using namespace std::chrono_literals;
using cobridge::Error;
using cobridge::web::WebServer;
using cobridge::web::test::http_exchange;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::StartsWith;

namespace {

// "Authorization: Basic " + base64("alice:s3cret") / base64("alice:nope").
constexpr const char* kAliceRight = "Authorization: Basic YWxpY2U6czNjcmV0\r\n";
constexpr const char* kAliceWrong = "Authorization: Basic YWxpY2U6bm9wZQ==\r\n";

std::string get(const std::string& path, const std::string& headers) {
  return "GET " + path + " HTTP/1.1\r\n" + headers + "Connection: close\r\n\r\n";
}

// What the "web" logger writes while alive.
class LogCapture {
 public:
  LogCapture() : sink_(std::make_shared<spdlog::sinks::ostream_sink_mt>(text_)) {
    sink_->set_pattern("%l %v");
    cobridge::sys::logger("web")->sinks().push_back(sink_);
  }
  ~LogCapture() {
    auto& sinks = cobridge::sys::logger("web")->sinks();
    sinks.erase(std::remove(sinks.begin(), sinks.end(), sink_), sinks.end());
  }
  LogCapture(const LogCapture&) = delete;
  LogCapture& operator=(const LogCapture&) = delete;
  [[nodiscard]] std::string text() {
    cobridge::sys::logger("web")->flush();
    return text_.str();
  }

 private:
  std::ostringstream text_;
  std::shared_ptr<spdlog::sinks::ostream_sink_mt> sink_;
};

std::size_t count_of(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(WebServerHost, Rfc9110Sec15_5_20_AForeignHostGets421AndAnOwnOne200) {
  std::atomic<int> calls{0};
  WebServer server([&] {
    ++calls;
    return cobridge::web::test::sample_report(1, 1);
  });
  cobridge::config::WebSettings s;  // bind 127.0.0.1
  s.port = 0;
  s.hosts = std::vector<std::string>{"gw1.plant.local"};
  const Error started = server.start(s);
  ASSERT_FALSE(started) << started.to_string();
  const std::string port = std::to_string(server.port());

  // A DNS-rebinding page's own name, with or without the port.
  const std::vector<std::string> foreign = {"evil.example", "evil.example:" + port, "gw2.plant.local", "10.1.2.3"};
  for (const std::string& host : foreign) {
    const std::string answer = http_exchange(server.port(), get("/api/v1/status", "Host: " + host + "\r\n"));
    EXPECT_THAT(answer, StartsWith("HTTP/1.1 421 ")) << host;
    EXPECT_THAT(answer, HasSubstr("misdirected request")) << host;
    EXPECT_THAT(answer, Not(HasSubstr("\"gateway\""))) << host;
  }
  EXPECT_EQ(calls.load(), 0) << "a misdirected request asked the daemon nothing";

  // RFC 9110 §7.2: the host, without the port, is one of the server's names.
  const std::vector<std::string> own = {"127.0.0.1:" + port,       "localhost:" + port, "LocalHost", "[::1]:" + port,
                                       "gw1.plant.local:" + port, "GW1.Plant.Local."};
  for (const std::string& host : own) {
    const std::string answer = http_exchange(server.port(), get("/api/v1/status", "Host: " + host + "\r\n"));
    EXPECT_THAT(answer, StartsWith("HTTP/1.1 200 ")) << host;
    EXPECT_THAT(answer, HasSubstr("\"gateway\":\"gw-1\"")) << host;
  }

  // RFC 9112 §3.2: two Host lines, or one that is not host[:port]: 400.
  EXPECT_THAT(http_exchange(server.port(), get("/healthz", "Host: localhost\r\nHost: evil.example\r\n")),
              StartsWith("HTTP/1.1 400 "));
  EXPECT_THAT(http_exchange(server.port(), get("/healthz", "Host: localhost:http\r\n")),
              StartsWith("HTTP/1.1 400 "));
  // HTTP/1.1 without Host: 400 too. HTTP/1.0 without Host is no browser's: served.
  EXPECT_THAT(http_exchange(server.port(), get("/healthz", "")), StartsWith("HTTP/1.1 400 "));
  EXPECT_THAT(http_exchange(server.port(), "GET /healthz HTTP/1.0\r\n\r\n"), StartsWith("HTTP/1.1 200 "));
  server.stop();
}

class WebServerLogin : public ::testing::Test {
 protected:
  void SetUp() override {
    std::ofstream(file_) << "alice:" << cobridge::web::test::kAliceHash << "\n";
    ::chmod(file_.c_str(), 0600);
  }
  void TearDown() override { std::filesystem::remove(file_); }
  std::filesystem::path file_ =
      std::filesystem::temp_directory_path() / ("cobridge-web-login-" + std::to_string(::getpid()));
};

TEST_F(WebServerLogin, Rfc6585Sec4_RepeatedBadPasswordsGet401Then429AndALogLine) {
  LogCapture log;
  WebServer server([] { return cobridge::web::test::sample_report(1, 1); });
  std::atomic<std::int64_t> advanced_ms{0};  // the backoff's clock, moved by the test instead of sleeping
  const auto start = std::chrono::steady_clock::now();
  server.set_clock([&] { return start + std::chrono::milliseconds(advanced_ms.load()); });
  cobridge::config::WebSettings s;
  s.port = 0;
  s.auth_file = file_;
  const Error started = server.start(s);
  ASSERT_FALSE(started) << started.to_string();
  const std::uint16_t port = server.port();
  const std::string host = "Host: 127.0.0.1\r\n";

  const std::string first = http_exchange(port, get("/metrics", host + kAliceWrong));
  EXPECT_THAT(first, StartsWith("HTTP/1.1 401 "));
  EXPECT_THAT(first, HasSubstr("WWW-Authenticate: Basic realm=\"cobridge\""));
  // In the window: 429 at once, even with the right password, with Retry-After.
  for (const char* credentials : {kAliceWrong, kAliceRight, ""}) {
    const std::string answer = http_exchange(port, get("/metrics", host + credentials));
    EXPECT_THAT(answer, StartsWith("HTTP/1.1 429 ")) << credentials;
    EXPECT_THAT(answer, HasSubstr("Retry-After: 1\r\n")) << credentials;
    EXPECT_THAT(answer, Not(HasSubstr("# HELP"))) << credentials;
  }
  // Another client (its own address) is not held up by this one's window.
  EXPECT_THAT(http_exchange(port, get("/metrics", host + kAliceRight), "127.0.0.2"), StartsWith("HTTP/1.1 200 "));

  // One line for the failure and the refusals of that second: the client and
  // the user, never the password.
  std::string text = log.text();
  EXPECT_EQ(count_of(text, "failed login"), 1U) << text;
  EXPECT_THAT(text, HasSubstr("warning web: failed login from 127.0.0.1 as \"alice\" (1 in a row); credentials not "
                              "checked for 1 s"));
  EXPECT_EQ(count_of(text, "refused (429)"), 0U) << "refusals within the second are counted, not logged:\n" << text;
  EXPECT_THAT(text, Not(HasSubstr("nope")));

  // After the window, a second failure doubles it; the line counts the refusals.
  advanced_ms += 1000;
  EXPECT_THAT(http_exchange(port, get("/metrics", host + kAliceWrong)), StartsWith("HTTP/1.1 401 "));
  EXPECT_THAT(http_exchange(port, get("/metrics", host + kAliceRight)), HasSubstr("Retry-After: 2\r\n"));
  text = log.text();
  EXPECT_THAT(text, HasSubstr("failed login from 127.0.0.1 as \"alice\" (2 in a row); credentials not checked for "
                              "2 s; since the last line: 0 more failed, 3 refused"));
  // And the right password after it is served.
  advanced_ms += 2000;
  EXPECT_THAT(http_exchange(port, get("/metrics", host + kAliceRight)), StartsWith("HTTP/1.1 200 "));
  server.stop();
}

}  // namespace
