#include "web/host_check.hpp"

#include "config/host_name.hpp"

#include <algorithm>

namespace cobridge::web {
namespace {

bool all_digits(std::string_view s) noexcept {
  return std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// uri-host [":" port] (RFC 9110 §7.2, RFC 3986 §3.2.2-3): the host part, or
// nullopt when the port is not digits or there is no host.
std::optional<std::string_view> host_part(std::string_view value) {
  std::size_t end = 0;
  if (!value.empty() && value.front() == '[') {
    end = value.find(']');
    if (end == std::string_view::npos) return std::nullopt;
    ++end;
  } else {
    end = std::min(value.find(':'), value.size());
  }
  const std::string_view rest = value.substr(end);
  if (!rest.empty() && (rest.front() != ':' || !all_digits(rest.substr(1)))) return std::nullopt;
  return value.substr(0, end);
}

bool is_loopback_name(std::string_view host) noexcept {
  return host == "localhost" || host == "127.0.0.1" || host == "::1";
}

}  // namespace

HostField parse_host_field(const char* value, unsigned lines, bool required) {
  HostField f;
  if (value == nullptr && !required) return f;
  f.kind = HostField::Kind::invalid;
  if (value == nullptr || lines > 1) return f;
  const auto part = host_part(value);
  const auto host = part ? config::canonical_host(*part) : std::nullopt;
  if (!host) return f;
  f.kind = HostField::Kind::host;
  f.host = *host;
  return f;
}

HostCheck::HostCheck(const config::WebSettings& settings) {
  const std::string bind = config::canonical_host(settings.bind).value_or(settings.bind);
  any_ = config::is_wildcard_address(bind) && !settings.hosts.has_value();
  bind_ = config::is_wildcard_address(bind) ? std::string() : bind;
  bind_loopback_ = config::is_loopback_address(bind);
  if (settings.hosts) hosts_ = *settings.hosts;
}

bool HostCheck::is_own_name(const std::string& host, std::string_view local) const {
  if (host == local || host == bind_) return true;
  if (is_loopback_name(host) && (bind_loopback_ || config::is_loopback_address(local))) return true;
  return std::find(hosts_.begin(), hosts_.end(), host) != hosts_.end();
}

HostCheck::Verdict HostCheck::check(const HostField& host, std::string_view local) const {
  switch (host.kind) {
    case HostField::Kind::absent: return Verdict::ok;
    case HostField::Kind::invalid: return Verdict::bad_request;
    case HostField::Kind::host: break;
  }
  if (any_ || is_own_name(host.host, local)) return Verdict::ok;
  return Verdict::misdirected;
}

std::string host_check_warning(const config::WebSettings& settings) {
  if (!settings.enabled || !HostCheck(settings).accepts_any()) return {};
  return "web.bind \"" + settings.bind +
         "\" without web.hosts: a request naming any Host is answered, so a web page can reach this "
         "gateway through a browser by DNS rebinding; list the names clients use in web.hosts "
         "(e.g. hosts = [\"gw1.plant.local\"]; hosts = [] for IP addresses only)";
}

}  // namespace cobridge::web
