// HttpRoute: what one HTTP request to the web service asks for, decided from
// its method and path alone. The service is read-only: GET and HEAD of four
// resources, anything else an error status with no effect on the daemon.
// Requests come from any host the service's address reaches, so every input
// gets a route or a 4xx, never a crash.
// Thread: any; a pure function.
#pragma once

#include <string_view>

namespace cobridge::web {

enum class Resource { none, page, status_json, metrics, health };

struct HttpRoute {
  Resource resource = Resource::none;
  unsigned status = 200;    // 200, or the error: 404, 405, 414
  bool head = false;        // HEAD: headers only
  const char* reason = "";  // the error's one-line text (the body of an error answer)
};

inline constexpr std::size_t kMaxPath = 256;

[[nodiscard]] HttpRoute route_request(std::string_view method, std::string_view path) noexcept;

// The Content-Type of each resource.
[[nodiscard]] const char* content_type(Resource r) noexcept;

}  // namespace cobridge::web
