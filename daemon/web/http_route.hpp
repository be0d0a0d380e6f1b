// HttpRoute: what one HTTP request to the web service asks for, decided from
// its method, its path and whether its target was clean. The service is
// read-only: GET and HEAD of five kinds of resource, anything else an error status
// with no effect on the daemon. Requests come from any host the service's
// address reaches, so every input gets a route or a 4xx, never a crash.
// Thread: any; pure functions.
#pragma once

#include <string_view>

namespace cobridge::web {

enum class Resource { none, page, status_json, metrics, health, capture };

struct HttpRoute {
  Resource resource = Resource::none;
  unsigned status = 200;    // 200, or the error: 400, 404, 405, 414
  bool head = false;        // HEAD: headers only
  const char* reason = "";  // the error's one-line text (the body of an error answer)
  std::string_view capture;  // Resource::capture: the capture's file name (a view into the path)
};

// The path prefix of a flight recorder capture: /api/v1/captures/NAME.
inline constexpr std::string_view kCapturePrefix = "/api/v1/captures/";

inline constexpr std::size_t kMaxPath = 256;

// The request target as the client sent it, before percent-decoding: true
// when it holds no control byte (0x00-0x1F, 0x7F), no space, and no
// percent-escape of a control byte (RFC 9112 §3.2 has no room for them).
// libmicrohttpd hands the target on as a C string, decoded, so a NUL, sent or
// as %00, cut it short: "/metrics\0x" was served as /metrics.
[[nodiscard]] bool is_clean_target(std::string_view raw) noexcept;

// `path`: the decoded path; `clean_target`: is_clean_target() of the request
// target as sent (false: 400, whatever the method and path).
[[nodiscard]] HttpRoute route_request(std::string_view method, std::string_view path,
                                      bool clean_target = true) noexcept;

// The Content-Type of each resource.
[[nodiscard]] const char* content_type(Resource r) noexcept;

}  // namespace cobridge::web
