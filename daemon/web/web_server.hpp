// WebServer: the daemon's read-only HTTP service (docs/web.md): the status
// page (/), the status JSON (/api/v1/status, the document `cobridge status
// --json` prints: one schema, built by the same to_json), Prometheus metrics
// (/metrics) and /healthz, on libmicrohttpd.
//
// It never touches the CAN path: it reads the status report the control
// socket also serves, and rebuilds it at most every `refresh` however many
// clients ask (so a hundred clients cost the bus managers what one costs).
// Bounded by construction: one internal thread (epoll), at most
// `max_clients` connections, a per-connection memory limit that caps the
// request header size, an idle timeout, GET and HEAD only, no request body
// read, a request target with a control byte or a space refused (400). TLS (GnuTLS, through libmicrohttpd) and HTTP basic authentication
// from a file of password hashes are optional.
//
// Before anything else a request's Host is checked (web/host_check.hpp:
// 421 for a name that is not the gateway's, against DNS rebinding). With
// authentication, a client's failed logins are logged and open a backoff
// window (web/login_throttle.hpp) in which it is answered 429 at once:
// nothing in a request waits, so one client never holds up another.
//
// Threads: start()/stop() on the main thread; requests are answered on
// libmicrohttpd's internal thread; handle() may be called from any thread
// (tests use it without a socket).
#pragma once

#include "base/error.hpp"
#include "base/result.hpp"
#include "config/config.hpp"
#include "control/status_report.hpp"
#include "web/auth_file.hpp"
#include "web/host_check.hpp"
#include "web/http_route.hpp"
#include "web/login_throttle.hpp"

#include <chrono>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

struct MHD_Daemon;

namespace cobridge::web {

// The files [web] names, checked as the daemon would load them (readable
// PEM files, an auth file readable by its owner only), for --check-config
// and start(). One Error per problem, where = "file:line:col: web.<key>".
[[nodiscard]] std::vector<Error> check_web_settings(const config::WebSettings& settings);

struct HttpAnswer {
  unsigned status = 200;
  const char* content_type = "text/plain; charset=utf-8";
  std::string body;         // also for HEAD: libmicrohttpd sends only its length
  std::size_t content_length = 0;
  bool ask_credentials = false;  // 401: send WWW-Authenticate
  long long retry_after_s = 0;   // 429: send Retry-After (RFC 6585 §4); 0 = none
};

struct Credentials {
  std::string_view user;
  std::string_view password;
};

// One request as handle() judges it.
struct HttpRequest {
  std::string_view method;
  std::string_view path;                     // decoded
  bool clean_target = true;                  // is_clean_target() of the target as sent
  const Credentials* credentials = nullptr;  // nullptr: none sent
  HostField host;                            // absent: no Host check (HTTP/1.0)
  std::string client;                        // the client's address, for the log ("" unknown)
  std::string throttle_key;                  // the client as LoginThrottle counts it (peer_address.hpp)
  std::string local;                         // the address the connection arrived at ("" unknown)
};

class WebServer {
 public:
  using StatusSource = std::function<control::StatusReport()>;
  // The text of a flight recorder capture by its file name (as the status
  // lists it); unset: none are served.
  using CaptureSource = std::function<Result<std::string>(std::string_view name)>;

  explicit WebServer(StatusSource source, std::chrono::milliseconds refresh = std::chrono::milliseconds(250));
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  // Loads the TLS files and the auth file, binds and starts the thread.
  // Fails with the first problem of check_web_settings, kInvalidArgument for
  // a bind that is not an IP address, kUnavailable when it cannot listen.
  [[nodiscard]] Error start(const config::WebSettings& settings);
  void stop();
  [[nodiscard]] bool running() const noexcept { return daemon_ != nullptr; }
  // The bound port (the configured one, or the kernel's choice for port 0 in tests).
  [[nodiscard]] std::uint16_t port() const noexcept { return port_; }

  // One request. Its checks in order: Host (400, 421), route (400, 404,
  // 405, 414), login (429, 401), then the resource.
  [[nodiscard]] HttpAnswer handle(const HttpRequest& request);
  // The same, for a request without Host from an unknown client (tests).
  [[nodiscard]] HttpAnswer handle(std::string_view method, std::string_view path, const Credentials* credentials,
                                  bool clean_target = true);
  // Test hooks, before requests: require these users (as if an auth file
  // were loaded); judge Host as `settings` would; the clock of the backoff.
  void set_auth(AuthFile auth) { auth_ = std::move(auth); }
  void set_captures(CaptureSource captures) { captures_ = std::move(captures); }
  void set_host_check(const config::WebSettings& settings) { host_check_ = HostCheck(settings); }
  void set_clock(std::function<LoginThrottle::Clock::time_point()> clock) { clock_ = std::move(clock); }

 private:
  struct Snapshot {
    std::chrono::steady_clock::time_point taken{};
    std::string json;
    std::string metrics;
    bool have_metrics = false;
    control::StatusReport report;
  };
  // The current status, rebuilt when older than refresh_; under mutex_.
  Snapshot& snapshot();
  // Each true when it answered the request (an error status in `a`).
  bool refuse_host(const HttpRequest& r, HttpAnswer& a) const;
  bool refuse_login(const HttpRequest& r, HttpAnswer& a);
  void serve(Resource resource, HttpAnswer& a);
  void serve_capture(std::string_view name, HttpAnswer& a);

  StatusSource source_;
  CaptureSource captures_;
  std::chrono::milliseconds refresh_;
  std::optional<AuthFile> auth_;
  HostCheck host_check_;  // any Host until start()
  LoginThrottle throttle_;
  std::function<LoginThrottle::Clock::time_point()> clock_ = [] { return LoginThrottle::Clock::now(); };
  std::mutex mutex_;  // the snapshot (one libmicrohttpd thread, plus tests)
  Snapshot snap_;
  std::string tls_cert_;
  std::string tls_key_;
  MHD_Daemon* daemon_ = nullptr;
  std::uint16_t port_ = 0;
};

}  // namespace cobridge::web
