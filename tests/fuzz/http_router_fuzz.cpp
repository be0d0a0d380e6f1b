// Fuzz target: the web service's request judgement (daemon/web/http_route.*,
// daemon/web/host_check.*, config/host_name.*): the target check, the route
// and the Host check that decide every answer's status before any resource
// is served (web_server.hpp: Host 400/421, then route 400/404/405/414).
// libmicrohttpd parses the bytes on the wire; this target hands on what it
// hands on, as it does: the request line's method, raw target (to the
// target callback as a C string, so a NUL ends it) and version, the path
// decoded (%XX, the query cut off, a C string again), the Host field lines.
// The first byte picks the [web] settings; the rest is the request.
// Invariants (abort on violation), as the headers and RFC 9110/9112 say:
//   * every request gets a route or a 4xx: status 200, 400, 404, 405 or
//     414, 200 exactly when a resource is named, an error with a reason;
//   * a target holding a control byte (sent, or %-encoded: %00..%1F, %7F) is
//     400 whatever the method (RFC 9112 §3.2; "/metrics\0x" was once served
//     as /metrics), and a 200's path holds no control byte;
//   * 200 only for GET and HEAD (read-only), HEAD marked; paths over
//     kMaxPath are 414; a capture is a file name under the prefix, never a
//     path ('/', "..", a leading '.');
//   * a Host that reads is canonical (canonical_host gives it back), two
//     Host lines or none in HTTP/1.1 are 400, and a Host is accepted exactly
//     when it is one of the gateway's own names (DNS rebinding, RFC 9110
//     §7.2, web/host_check.hpp).
#include <strings.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "config/host_name.hpp"
#include "web/host_check.hpp"
#include "web/http_route.hpp"

using namespace cobridge;
using web::HostCheck;
using web::HostField;
using web::HttpRoute;

namespace {

// What libmicrohttpd hands on of one request.
struct Request {
  std::string_view method, target, version;
  std::string host;       // the first Host line's value
  unsigned host_lines = 0;
};

std::string_view c_string(std::string_view s) { return s.substr(0, std::min(s.find('\0'), s.size())); }

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

std::string_view next_line(std::string_view& text) {
  const std::size_t end = std::min(text.find('\n'), text.size());
  std::string_view line = text.substr(0, end);
  text.remove_prefix(std::min(end + 1, text.size()));
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return line;
}

Request parse(std::string_view text) {
  Request r;
  std::string_view line = next_line(text);
  const std::size_t sp1 = std::min(line.find(' '), line.size());
  r.method = line.substr(0, sp1);
  line.remove_prefix(std::min(sp1 + 1, line.size()));
  const std::size_t sp2 = std::min(line.find(' '), line.size());
  r.target = line.substr(0, sp2);
  r.version = line.substr(std::min(sp2 + 1, line.size()));
  for (std::string_view h = next_line(text); !h.empty(); h = next_line(text)) {
    const std::size_t colon = h.find(':');
    if (colon == std::string_view::npos || h.substr(0, colon).size() != 4 ||
        ::strncasecmp(h.data(), "host", 4) != 0)
      continue;
    if (r.host_lines++ == 0) r.host = std::string(c_string(trim(h.substr(colon + 1))));
  }
  return r;
}

int hex(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// The path as libmicrohttpd decodes it: the query cut off, %XX decoded.
std::string decoded_path(std::string_view target) {
  target = target.substr(0, std::min(target.find('?'), target.size()));
  std::string out;
  for (std::size_t i = 0; i < target.size(); ++i) {
    if (target[i] == '%' && i + 2 < target.size() && hex(target[i + 1]) >= 0 && hex(target[i + 2]) >= 0) {
      out += static_cast<char>(hex(target[i + 1]) * 16 + hex(target[i + 2]));
      i += 2;
    } else {
      out += target[i];
    }
  }
  return std::string(c_string(out));
}

bool control(unsigned c) { return c < 0x20 || c == 0x7F; }

// A control byte in the target as sent: raw, or as %XX.
bool holds_control(std::string_view target) {
  for (std::size_t i = 0; i < target.size(); ++i) {
    if (control(static_cast<unsigned char>(target[i]))) return true;
    if (target[i] == '%' && i + 2 < target.size() && hex(target[i + 1]) >= 0 && hex(target[i + 2]) >= 0 &&
        control(static_cast<unsigned>(hex(target[i + 1]) * 16 + hex(target[i + 2]))))
      return true;
  }
  return false;
}

void check_route(const Request& r, std::string_view method, const std::string& path, const HttpRoute& route) {
  const bool ok = route.status == 200;
  if (route.status != 200 && route.status != 400 && route.status != 404 && route.status != 405 &&
      route.status != 414)
    std::abort();
  if (ok != (route.resource != web::Resource::none) || (!ok && std::string_view(route.reason).empty())) std::abort();
  if (web::content_type(route.resource) == nullptr) std::abort();
  if (holds_control(r.target) && route.status != 400) std::abort();
  const bool readable = !holds_control(r.target) && (method == "GET" || method == "HEAD");
  if (readable && path.size() > web::kMaxPath && route.status != 414) std::abort();
  if (!holds_control(r.target) && method != "GET" && method != "HEAD" && route.status != 405) std::abort();
  if (ok && (method != "GET" && method != "HEAD")) std::abort();
  if (ok && (route.head != (method == "HEAD") || path.size() > web::kMaxPath || holds_control(path))) std::abort();
  if (route.resource == web::Resource::capture) {
    const std::string_view name = route.capture;
    if (path != std::string(web::kCapturePrefix) + std::string(name) || name.find('/') != std::string_view::npos ||
        name.find("..") != std::string_view::npos || name.front() == '.' || !name.ends_with(".log"))
      std::abort();
  }
}

struct Site {
  config::WebSettings settings;
  std::string local;                   // the address the connection arrived at
  std::array<std::string_view, 3> own;  // the Hosts it must accept; all when `any`
  bool any;
};

const Site& site(std::uint8_t pick) {
  static const std::array<Site, 3> sites = [] {
    std::array<Site, 3> s;
    s[0].settings.bind = "0.0.0.0";  // no web.hosts: any Host
    s[0].local = "192.0.2.10";
    s[0].any = true;
    s[1].settings.bind = "192.0.2.10";
    s[1].settings.hosts = std::vector<std::string>{"gw1.plant.local"};
    s[1].local = "192.0.2.10";
    s[1].own = {"192.0.2.10", "gw1.plant.local", "192.0.2.10"};
    s[1].any = false;
    s[2].settings.bind = "127.0.0.1";
    s[2].settings.hosts = std::vector<std::string>{};
    s[2].local = "127.0.0.1";
    s[2].own = {"127.0.0.1", "localhost", "::1"};
    s[2].any = false;
    return s;
  }();
  return sites[pick % sites.size()];
}

void check_host(const Request& r, const Site& s) {
  const bool required = c_string(r.version) != "HTTP/1.0";
  const HostField f = web::parse_host_field(r.host_lines == 0 ? nullptr : r.host.c_str(), r.host_lines, required);
  if (r.host_lines > 1 && f.kind != HostField::Kind::invalid) std::abort();
  if (r.host_lines == 0 && f.kind != (required ? HostField::Kind::invalid : HostField::Kind::absent)) std::abort();
  if (f.kind == HostField::Kind::host && (f.host.empty() || config::canonical_host(f.host) != f.host)) std::abort();
  const HostCheck::Verdict v = HostCheck(s.settings).check(f, s.local);
  HostCheck::Verdict want = HostCheck::Verdict::ok;
  if (f.kind == HostField::Kind::invalid) want = HostCheck::Verdict::bad_request;
  if (f.kind == HostField::Kind::host && !s.any && std::find(s.own.begin(), s.own.end(), f.host) == s.own.end())
    want = HostCheck::Verdict::misdirected;
  if (v != want) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  const Request r = parse(text);
  const std::string_view raw = c_string(r.target);  // the target callback's C string
  // Clean only when the C string reaches the version: a NUL sent leaves a gap.
  const bool clean = web::is_clean_target(raw) && raw.size() == r.target.size();
  const std::string path = decoded_path(r.target);
  const std::string_view method = c_string(r.method);
  const HttpRoute route = web::route_request(method, path, clean);
  check_route(r, method, path, route);
  check_host(r, site(data[0]));
  return 0;
}
