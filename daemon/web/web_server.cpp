#include "web/web_server.hpp"

#include "sys/logging.hpp"
#include "web/login_log.hpp"
#include "web/metrics.hpp"
#include "web/microhttpd.hpp"
#include "web/peer_address.hpp"
#include "web/status_page.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <strings.h>

#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

namespace cobridge::web {
namespace {

constexpr std::size_t kConnectionMemory = 16 * 1024;  // request line + headers, per connection

// `e` placed at the [web] key the configuration names it with:
// where = "file:line:col: web.<key>" (then the file's own place, if any).
Error at(Error e, const config::SourceLocation& l, std::string_view key) {
  e.where = l.to_string() + ": web." + std::string(key) + (e.where.empty() ? "" : ": " + e.where);
  return e;
}

Error read_pem(const std::filesystem::path& file, std::string& out) {
  std::ifstream in(file, std::ios::binary);
  if (!in) return Error(Errc::kNotFound, "cannot read " + file.string());
  std::ostringstream s;
  s << in.rdbuf();
  out = s.str();
  if (out.find("-----BEGIN ") == std::string::npos) return Error(Errc::kInvalidArgument, file.string() + " is not a PEM file");
  return {};
}

void mhd_log(void* /*cls*/, const char* fmt, va_list ap) {
  std::array<char, 512> buf{};
  std::vsnprintf(buf.data(), buf.size(), fmt, ap);
  std::string text(buf.data());
  while (!text.empty() && text.back() == '\n') text.pop_back();
  sys::logger("web")->debug("libmicrohttpd: {}", text);
}

// libmicrohttpd calls this with the request target as sent, before it
// decodes it in place, and gives what it returns to on_request as the
// request's state: where the target's C string ends, or nullptr when the
// target is not clean. The target ends where libmicrohttpd wrote a NUL over
// the space before the version; a NUL the client sent ends the C string
// before that, and on_request sees the gap (target_was_clean).
void* on_target(void* /*cls*/, const char* uri, MHD_Connection* /*connection*/) {
  const std::string_view raw(uri);
  return is_clean_target(raw) ? const_cast<char*>(uri + raw.size()) : nullptr;
}

bool target_was_clean(const void* state, const char* version) {
  const auto* end = static_cast<const char*>(state);
  return end != nullptr && version != nullptr && end + 1 == version;
}

// The callbacks run on libmicrohttpd's thread, so the library is loaded.
const Microhttpd& mhd() { return *microhttpd().value(); }

MHD_Result count_host_lines(void* cls, MHD_ValueKind /*kind*/, const char* key, const char* /*value*/) {
  if (::strcasecmp(key, MHD_HTTP_HEADER_HOST) == 0) ++*static_cast<unsigned*>(cls);
  return MHD_YES;
}

// The Host field (all its lines counted: two are a 400; required from
// HTTP/1.1 on) and both ends of the connection.
void read_origin(MHD_Connection* connection, const char* version, HttpRequest& r) {
  unsigned lines = 0;
  mhd().get_connection_values(connection, MHD_HEADER_KIND, &count_host_lines, &lines);
  const bool required = version == nullptr || std::strcmp(version, MHD_HTTP_VERSION_1_0) != 0;
  r.host = parse_host_field(mhd().lookup_connection_value(connection, MHD_HEADER_KIND, MHD_HTTP_HEADER_HOST), lines,
                            required);
  if (const MHD_ConnectionInfo* ci = mhd().get_connection_info(connection, MHD_CONNECTION_INFO_CLIENT_ADDRESS)) {
    r.client = address_text(ci->client_addr);
    r.throttle_key = throttle_key(ci->client_addr);
  }
  if (const MHD_ConnectionInfo* ci = mhd().get_connection_info(connection, MHD_CONNECTION_INFO_CONNECTION_FD))
    r.local = local_address(ci->connect_fd);
}

MHD_Result on_request(void* cls, MHD_Connection* connection, const char* url, const char* method,
                      const char* version, const char* /*upload_data*/, std::size_t* /*upload_data_size*/,
                      void** request_state) {
  auto* server = static_cast<WebServer*>(cls);
  char* password = nullptr;
  char* user = mhd().basic_auth_get_username_password(connection, &password);
  Credentials credentials{user != nullptr ? user : "", password != nullptr ? password : ""};
  HttpAnswer a;
  try {
    HttpRequest r;
    r.method = method;
    r.path = url;
    r.clean_target = target_was_clean(*request_state, version);
    r.credentials = user != nullptr ? &credentials : nullptr;
    read_origin(connection, version, r);
    a = server->handle(r);
  } catch (const std::exception& e) {
    a.status = 500;
    a.body = "internal error\n";
    a.content_length = a.body.size();
    sys::logger("web")->error("{} {}: {}", method, url, e.what());
  }
  if (user != nullptr) mhd().free(user);
  if (password != nullptr) mhd().free(password);

  MHD_Response* response = mhd().create_response_from_buffer(a.body.size(), a.body.data(), MHD_RESPMEM_MUST_COPY);
  if (response == nullptr) return MHD_NO;
  mhd().add_response_header(response, MHD_HTTP_HEADER_CONTENT_TYPE, a.content_type);
  mhd().add_response_header(response, MHD_HTTP_HEADER_CACHE_CONTROL, "no-store");
  mhd().add_response_header(response, "X-Content-Type-Options", "nosniff");
  mhd().add_response_header(response, "X-Frame-Options", "DENY");
  mhd().add_response_header(response, "Content-Security-Policy",
                          "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; "
                          "connect-src 'self'; img-src data:; base-uri 'none'; form-action 'none'");
  if (a.status == 405) mhd().add_response_header(response, MHD_HTTP_HEADER_ALLOW, "GET, HEAD");
  if (a.retry_after_s > 0)
    mhd().add_response_header(response, MHD_HTTP_HEADER_RETRY_AFTER, std::to_string(a.retry_after_s).c_str());
  MHD_Result r;
  if (a.ask_credentials)
    r = mhd().queue_basic_auth_fail_response(connection, "cobridge", response);
  else
    r = mhd().queue_response(connection, a.status, response);
  mhd().destroy_response(response);
  return r;
}

}  // namespace

std::vector<Error> check_web_settings(const config::WebSettings& settings) {
  std::vector<Error> errors;
  if (!settings.enabled) return errors;
  std::string text;
  if (!settings.tls_cert.empty()) {
    if (Error e = read_pem(settings.tls_cert, text)) errors.push_back(at(std::move(e), settings.tls_cert_at, "tls_cert"));
  }
  if (!settings.tls_key.empty()) {
    if (Error e = read_pem(settings.tls_key, text)) errors.push_back(at(std::move(e), settings.tls_key_at, "tls_key"));
  }
  if (!settings.tls_cert.empty() || !settings.tls_key.empty()) {
    const Result<const Microhttpd*> lib = microhttpd();
    if (!lib.ok())
      errors.push_back(at(Error(Errc::kUnavailable, "cannot load the HTTP library: " + lib.error().to_string()),
                          settings.tls_cert_at, "tls_cert"));
    else if (lib.value()->is_feature_supported(MHD_FEATURE_TLS) != MHD_YES)
      errors.push_back(at(Error(Errc::kUnsupported, "this libmicrohttpd was built without TLS"), settings.tls_cert_at,
                          "tls_cert"));
  }
  if (!settings.auth_file.empty()) {
    AuthFile auth;
    if (Error e = auth.load(settings.auth_file)) errors.push_back(at(std::move(e), settings.auth_file_at, "auth_file"));
  }
  return errors;
}

WebServer::WebServer(StatusSource source, std::chrono::milliseconds refresh)
    : source_(std::move(source)), refresh_(refresh) {}

WebServer::~WebServer() { stop(); }

Error WebServer::start(const config::WebSettings& settings) {
  stop();
  const Result<const Microhttpd*> loaded = microhttpd();
  if (!loaded.ok()) return Error(Errc::kUnavailable, "cannot load the HTTP library: " + loaded.error().to_string());
  const Microhttpd* lib = loaded.value();
  auto problems = check_web_settings(settings);
  if (!problems.empty()) return std::move(problems.front());
  if (!settings.auth_file.empty()) {
    AuthFile auth;
    if (Error e = auth.load(settings.auth_file)) return at(std::move(e), settings.auth_file_at, "auth_file");
    auth_ = std::move(auth);
  }
  host_check_ = HostCheck(settings);  // host_check_warning() is among the exposure warnings (app/exposure.cpp)
  unsigned flags = MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_EPOLL | MHD_USE_ERROR_LOG;
  const bool tls = !settings.tls_cert.empty();
  if (tls) {
    if (Error e = read_pem(settings.tls_cert, tls_cert_)) return at(std::move(e), settings.tls_cert_at, "tls_cert");
    if (Error e = read_pem(settings.tls_key, tls_key_)) return at(std::move(e), settings.tls_key_at, "tls_key");
    flags |= MHD_USE_TLS;
  }
  sockaddr_in v4{};
  sockaddr_in6 v6{};
  const sockaddr* addr = nullptr;
  if (::inet_pton(AF_INET, settings.bind.c_str(), &v4.sin_addr) == 1) {
    v4.sin_family = AF_INET;
    v4.sin_port = htons(settings.port);
    addr = reinterpret_cast<const sockaddr*>(&v4);
  } else if (::inet_pton(AF_INET6, settings.bind.c_str(), &v6.sin6_addr) == 1) {
    v6.sin6_family = AF_INET6;
    v6.sin6_port = htons(settings.port);
    addr = reinterpret_cast<const sockaddr*>(&v6);
    flags |= MHD_USE_IPv6;
  } else {
    return Error(Errc::kInvalidArgument, "web.bind \"" + settings.bind + "\" is not an IP address");
  }
  std::vector<MHD_OptionItem> options{
      {MHD_OPTION_CONNECTION_LIMIT, static_cast<intptr_t>(settings.max_clients), nullptr},
      {MHD_OPTION_CONNECTION_TIMEOUT, static_cast<intptr_t>(settings.timeout_s), nullptr},
      {MHD_OPTION_CONNECTION_MEMORY_LIMIT, static_cast<intptr_t>(kConnectionMemory), nullptr},
      {MHD_OPTION_SOCK_ADDR, 0, const_cast<sockaddr*>(addr)},
      {MHD_OPTION_EXTERNAL_LOGGER, reinterpret_cast<intptr_t>(&mhd_log), nullptr},
      {MHD_OPTION_URI_LOG_CALLBACK, reinterpret_cast<intptr_t>(&on_target), nullptr},
  };
  if (tls) {
    options.push_back({MHD_OPTION_HTTPS_MEM_CERT, 0, tls_cert_.data()});
    options.push_back({MHD_OPTION_HTTPS_MEM_KEY, 0, tls_key_.data()});
  }
  options.push_back({MHD_OPTION_END, 0, nullptr});
  daemon_ = lib->start_daemon(flags, settings.port, nullptr, nullptr, &on_request, this, MHD_OPTION_ARRAY,
                             options.data(), MHD_OPTION_END);
  if (daemon_ == nullptr) {
    return Error(Errc::kUnavailable, "cannot listen on " + settings.bind + " port " + std::to_string(settings.port) +
                                         " (address in use, not local, or a bad TLS certificate/key)");
  }
  port_ = settings.port;
  if (const MHD_DaemonInfo* info = lib->get_daemon_info(daemon_, MHD_DAEMON_INFO_BIND_PORT)) port_ = info->port;
  sys::logger("web")->info("web: serving http{}://{}:{}/ ({} clients at most{})", tls ? "s" : "", settings.bind, port_,
                           settings.max_clients, auth_ ? ", basic authentication" : "");
  return {};
}

void WebServer::stop() {
  if (daemon_ == nullptr) return;
  mhd().stop_daemon(daemon_);
  daemon_ = nullptr;
}

WebServer::Snapshot& WebServer::snapshot() {
  const auto now = std::chrono::steady_clock::now();
  if (snap_.taken == std::chrono::steady_clock::time_point{} || now - snap_.taken >= refresh_) {
    snap_.report = source_();
    snap_.json = control::to_json(snap_.report);
    snap_.json += '\n';
    snap_.have_metrics = false;
    snap_.taken = now;
  }
  return snap_;
}

namespace {

void refuse(HttpAnswer& a, unsigned status, const std::string& why) {
  a.status = status;
  a.content_type = content_type(Resource::none);
  a.body = why + "\n";
}

bool refuse_route(const HttpRoute& route, HttpAnswer& a) {
  if (route.status == 200) return false;
  refuse(a, route.status, route.reason);
  return true;
}

}  // namespace

HttpAnswer WebServer::handle(std::string_view method, std::string_view path, const Credentials* credentials,
                             bool clean_target) {
  HttpRequest r;
  r.method = method;
  r.path = path;
  r.credentials = credentials;
  r.clean_target = clean_target;
  return handle(r);
}

HttpAnswer WebServer::handle(const HttpRequest& request) {
  HttpAnswer a;
  const HttpRoute route = route_request(request.method, request.path, request.clean_target);
  a.content_type = content_type(route.resource);
  if (!refuse_host(request, a) && !refuse_route(route, a) && !refuse_login(request, a)) {
    if (route.resource == Resource::capture) {
      serve_capture(route.capture, a);
    } else {
      serve(route.resource, a);
    }
  }
  // HEAD keeps the body here: libmicrohttpd sends its length and not the bytes.
  a.content_length = a.body.size();
  return a;
}

bool WebServer::refuse_host(const HttpRequest& r, HttpAnswer& a) const {
  switch (host_check_.check(r.host, r.local)) {
    case HostCheck::Verdict::ok: return false;
    case HostCheck::Verdict::bad_request:
      refuse(a, 400, "bad request: the Host header must be one host[:port] (RFC 9112 section 3.2)");
      return true;
    case HostCheck::Verdict::misdirected:
      refuse(a, 421, "misdirected request: this server does not answer for that Host (web.hosts lists its names)");
      return true;
  }
  return false;
}

bool WebServer::refuse_login(const HttpRequest& r, HttpAnswer& a) {
  if (!auth_) return false;
  const std::string& client = r.throttle_key.empty() ? r.client : r.throttle_key;
  const std::string_view user = r.credentials != nullptr ? r.credentials->user : std::string_view();
  const auto now = clock_();
  if (const auto wait = throttle_.wait(client, now); wait > LoginThrottle::Clock::duration::zero()) {
    // In the backoff window: answered at once, the credentials not even hashed.
    const LoginThrottle::Verdict v = throttle_.refused(client, now);
    if (v.log) sys::logger("web")->warn("web: {}", refused_login_line(r.client, user, v));
    a.retry_after_s = seconds_up(wait);
    refuse(a, 429, "too many failed logins from this address: retry after " + std::to_string(a.retry_after_s) + " s");
    return true;
  }
  if (r.credentials != nullptr && auth_->check(user, r.credentials->password)) {
    throttle_.succeeded(client);
    return false;
  }
  if (r.credentials != nullptr) {  // none sent is a browser's first request, not a failure
    const LoginThrottle::Verdict v = throttle_.failed(client, now);
    if (v.log) sys::logger("web")->warn("web: {}", failed_login_line(r.client, user, v));
  }
  refuse(a, 401, "authentication required");
  a.ask_credentials = true;
  return true;
}

// A capture file, as `cobridge capture get` reads it (only a name the
// recorder lists; nothing outside its directory).
void WebServer::serve_capture(std::string_view name, HttpAnswer& a) {
  if (!captures_) {
    refuse(a, 404, "no flight recorder");
    return;
  }
  Result<std::string> text = captures_(name);
  if (!text.ok()) {
    refuse(a, text.error().kind == Errc::kNotFound ? 404 : 503, text.error().message);
    return;
  }
  a.body = std::move(text.value());
}

void WebServer::serve(Resource resource, HttpAnswer& a) {
  switch (resource) {
    case Resource::page: a.body = std::string(status_page_html()); break;
    case Resource::health: a.body = "ok\n"; break;
    case Resource::status_json: {
      const std::lock_guard lock(mutex_);
      a.body = snapshot().json;
      break;
    }
    case Resource::metrics: {
      const std::lock_guard lock(mutex_);
      Snapshot& s = snapshot();
      if (!s.have_metrics) {
        s.metrics = render_metrics(s.report);
        s.have_metrics = true;
      }
      a.body = s.metrics;
      break;
    }
    case Resource::capture:
    case Resource::none: break;
  }
}

}  // namespace cobridge::web
