// HostCheck: which Host a request to the web service may name (RFC 9110
// §7.2), against DNS rebinding: a page of any web site can have a browser
// on the plant network resolve its own name to the gateway's address and
// then read the gateway's answers as the same origin, unless the gateway
// refuses a Host that is not one of its own names. Such a request gets 421
// Misdirected Request (RFC 9110 §15.5.20); a Host that is not host[:port],
// or more than one, gets 400 (RFC 9112 §3.2).
//
// Accepted: the address the connection arrived at (for a specific bind, the
// bind address), written as an IP literal; "localhost", 127.0.0.1 and [::1]
// when that address or the bind is the loopback; each web.hosts name. With
// a wildcard bind (0.0.0.0, ::) and no web.hosts at all, any Host is
// accepted (the gateway cannot know its names) and host_check_warning()
// says so. An HTTP/1.0 request without Host is not a browser's and passes;
// an HTTP/1.1 one gets 400 (RFC 9112 §3.2).
//
// Thread: built on the main thread by WebServer::start(); check() from any
// (read-only).
#pragma once

#include "config/config.hpp"

#include <string>
#include <string_view>
#include <vector>

namespace cobridge::web {

// A request's Host header field as the server reads it.
struct HostField {
  enum class Kind { absent, invalid, host };
  Kind kind = Kind::absent;
  std::string host;  // Kind::host: canonical (config/host_name.hpp), the port cut off
};

// `value`: the field's value, nullptr when the request has none; `lines`:
// how many Host field lines the request had (two or more: invalid);
// `required`: the request is HTTP/1.1, where a missing Host is invalid too
// (RFC 9112 §3.2; libmicrohttpd 0.9.75 does not refuse it), else absent.
[[nodiscard]] HostField parse_host_field(const char* value, unsigned lines, bool required = true);

class HostCheck {
 public:
  enum class Verdict { ok, bad_request, misdirected };

  HostCheck() = default;  // accepts any Host (a WebServer that was never started: tests)
  explicit HostCheck(const config::WebSettings& settings);

  // `local`: the address the connection arrived at, canonical; "" when unknown.
  [[nodiscard]] Verdict check(const HostField& host, std::string_view local) const;
  [[nodiscard]] bool accepts_any() const noexcept { return any_; }

 private:
  [[nodiscard]] bool is_own_name(const std::string& host, std::string_view local) const;

  bool any_ = true;
  std::string bind_;  // canonical; "" for a wildcard bind
  bool bind_loopback_ = false;
  std::vector<std::string> hosts_;
};

// The warning for [web] settings under which any Host is accepted (a
// wildcard bind without web.hosts), naming the fix; "" when there is none.
// One of the exposure warnings (app/exposure.cpp): printed by --check-config
// and logged at start and on reload, at the [web] table's file:line:col.
[[nodiscard]] std::string host_check_warning(const config::WebSettings& settings);

}  // namespace cobridge::web
