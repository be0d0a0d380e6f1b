#include "web/http_route.hpp"

namespace cobridge::web {

HttpRoute route_request(std::string_view method, std::string_view path) noexcept {
  HttpRoute r;
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
  } else {
    r.status = 404;
    r.reason = "not found (resources: /, /api/v1/status, /metrics, /healthz)";
  }
  return r;
}

const char* content_type(Resource r) noexcept {
  switch (r) {
    case Resource::page: return "text/html; charset=utf-8";
    case Resource::status_json: return "application/json";
    case Resource::metrics: return "text/plain; version=0.0.4; charset=utf-8";
    case Resource::health:
    case Resource::none: break;
  }
  return "text/plain; charset=utf-8";
}

}  // namespace cobridge::web
