#include "web/http_route.hpp"

namespace cobridge::web {
namespace {

bool is_control(unsigned char c) noexcept { return c < 0x20 || c == 0x7F; }

int hex_digit(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// "%XX" at `i` standing for a control byte.
bool escapes_control(std::string_view s, std::size_t i) noexcept {
  if (s[i] != '%' || i + 2 >= s.size()) return false;
  const int high = hex_digit(s[i + 1]);
  const int low = hex_digit(s[i + 2]);
  return high >= 0 && low >= 0 && is_control(static_cast<unsigned char>(high * 16 + low));
}

// A capture's file name as the recorder writes it: letters, digits, '-',
// '_', '.', ending in ".log"; never a path.
bool capture_name_ok(std::string_view name) noexcept {
  if (name.size() < 5 || !name.ends_with(".log") || name.front() == '.') return false;
  for (const char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' ||
                    c == '_' || c == '.';
    if (!ok) return false;
  }
  return name.find("..") == std::string_view::npos;
}

}  // namespace

bool is_clean_target(std::string_view raw) noexcept {
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const auto c = static_cast<unsigned char>(raw[i]);
    if (is_control(c) || c == ' ' || escapes_control(raw, i)) return false;
  }
  return true;
}

HttpRoute route_request(std::string_view method, std::string_view path, bool clean_target) noexcept {
  HttpRoute r;
  if (!clean_target) {
    r.status = 400;
    r.reason = "bad request target: it may hold no control byte and no space, sent or percent-encoded";
    return r;
  }
  if (method == "HEAD") {
    r.head = true;
  } else if (method != "GET") {
    r.status = 405;
    r.reason = "method not allowed: this service is read-only (GET, HEAD)";
    return r;
  }
  if (path.size() > kMaxPath) {
    r.status = 414;
    r.reason = "request path too long";
    return r;
  }
  if (path == "/" || path == "/index.html") {
    r.resource = Resource::page;
  } else if (path == "/api/v1/status") {
    r.resource = Resource::status_json;
  } else if (path == "/metrics") {
    r.resource = Resource::metrics;
  } else if (path == "/healthz") {
    r.resource = Resource::health;
  } else if (path.starts_with(kCapturePrefix) && capture_name_ok(path.substr(kCapturePrefix.size()))) {
    r.resource = Resource::capture;
    r.capture = path.substr(kCapturePrefix.size());
  } else {
    r.status = 404;
    r.reason = "not found (resources: /, /api/v1/status, /metrics, /healthz, /api/v1/captures/NAME)";
  }
  return r;
}

const char* content_type(Resource r) noexcept {
  switch (r) {
    case Resource::page: return "text/html; charset=utf-8";
    case Resource::status_json: return "application/json";
    case Resource::metrics: return "text/plain; version=0.0.4; charset=utf-8";
    case Resource::capture: return "text/plain; charset=utf-8";  // a candump -l log
    case Resource::health:
    case Resource::none: break;
  }
  return "text/plain; charset=utf-8";
}

}  // namespace cobridge::web
