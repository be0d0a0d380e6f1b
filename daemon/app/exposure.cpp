#include "app/exposure.hpp"

#include "web/host_check.hpp"

#include <cobridge/ip_allow_list.hpp>

#include <arpa/inet.h>
#include <sys/stat.h>

#include <toml++/toml.h>

#include <cstdio>
#include <optional>

namespace cobridge::app {
namespace {

std::string mode_text(mode_t mode) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%04o", static_cast<unsigned>(mode & 07777));
  return buf;
}

void web_exposure(const config::WebSettings& w, std::vector<std::string>& out) {
  if (!w.enabled) return;
  const std::string here = w.where.to_string() + ": [web] serves " + w.bind + ":" + std::to_string(w.port);
  if (!is_loopback(w.bind) && w.tls_cert.empty())
    out.push_back(here + " on a non-loopback address without TLS: passwords and the status cross the network in "
                         "clear text (tls_cert/tls_key, or a reverse proxy: docs/security.md)");
  if (!is_loopback(w.bind) && w.auth_file.empty())
    out.push_back(here + " on a non-loopback address without authentication (auth_file): whoever reaches it reads "
                         "every device's status and the metrics");
  if (const std::string any_host = web::host_check_warning(w); !any_host.empty())
    out.push_back(w.where.to_string() + ": " + any_host);
  struct stat st {};
  if (!w.tls_key.empty() && ::stat(w.tls_key.c_str(), &st) == 0 && (st.st_mode & (S_IRWXG | S_IRWXO)) != 0)
    out.push_back(w.tls_key_at.to_string() + ": web.tls_key " + w.tls_key.string() +
                  " is readable or writable by group or others (mode " + mode_text(st.st_mode) + "): chmod 600");
}

// Does a write_allow list take this host's own loopback clients (127.0.0.1
// or ::1)? Then every local account writes around write_group
// (IpAllowList::allows_writer): said even for a loopback listener.
bool takes_local_writers(const std::vector<std::string>& cidrs) {
  IpAllowList list;
  for (const auto& c : cidrs) (void)list.add(c);
  if (list.empty()) return false;
  sockaddr_in6 v6{};
  v6.sin6_family = AF_INET6;
  v6.sin6_addr = in6addr_loopback;
  return list.contains_v4(INADDR_LOOPBACK) || list.contains(reinterpret_cast<const sockaddr*>(&v6));
}

constexpr const char* kNoWriter =
    " with writes_enabled on the loopback address, and write_allow does not list it: every write is refused "
    "(a loopback client writes only when write_allow lists it, e.g. [\"127.0.0.1/32\"])";

constexpr const char* kLocalWriters =
    " takes writes from this host's loopback address (write_allow lists it): every local account writes to the "
    "devices, around write_group";

void ascii_exposure(const config::AsciiGatewaySettings& a, std::vector<std::string>& out) {
  if (!a.enabled || a.tcp_port == 0) return;
  const std::string here = a.where + ": [ascii_gateway] listens on " + a.bind + ":" + std::to_string(a.tcp_port);
  if (a.writes_enabled && takes_local_writers(a.write_allow)) out.push_back(here + kLocalWriters);
  if (is_loopback(a.bind)) {
    if (a.writes_enabled && !takes_local_writers(a.write_allow)) out.push_back(here + kNoWriter);
    return;
  }
  out.push_back(here + " (non-loopback); CiA 309-3 has no authentication: whoever reaches the port reads any "
                       "object of any device");
  if (a.writes_enabled && a.write_allow.empty())
    out.push_back(here + " with writes_enabled and no write_allow: whoever reaches the port writes to the devices");
}

// An output's table read by convention; nothing when it does not parse (the plugin says why).
void output_exposure(const config::Output& o, std::vector<std::string>& out) {
  if (!o.enabled) return;
  toml::table t;
  try {
    t = toml::parse(o.settings_toml);
  } catch (const toml::parse_error&) {
    return;
  }
  const std::optional<std::string> bind = t["bind"].value<std::string>();
  const toml::array* allow = t["write_allow"].as_array();
  const std::string here = o.where.to_string() + ": [outputs." + o.name + "] listens on " + bind.value_or("?");
  const bool writes = bind && t["writes_enabled"].value_or(false);
  std::vector<std::string> cidrs;
  if (allow != nullptr)
    for (const auto& e : *allow) cidrs.push_back(e.value_or(std::string()));
  if (writes && takes_local_writers(cidrs)) out.push_back(here + kLocalWriters);
  if (!bind) return;
  if (is_loopback(*bind)) {
    if (writes && !takes_local_writers(cidrs)) out.push_back(here + kNoWriter);
    return;
  }
  out.push_back(here + " (non-loopback) without authentication: whoever reaches it reads every value");
  if (t["writes_enabled"].value_or(false) && (allow == nullptr || allow->empty()))
    out.push_back(here + " with writes_enabled and no write_allow: whoever reaches it presets, resets and stores "
                         "encoders");
}

}  // namespace

bool is_loopback(const std::string& address) {
  in_addr a4{};
  if (::inet_pton(AF_INET, address.c_str(), &a4) == 1) return (ntohl(a4.s_addr) >> 24) == 127;
  in6_addr a6{};
  return ::inet_pton(AF_INET6, address.c_str(), &a6) == 1 && IN6_IS_ADDR_LOOPBACK(&a6);
}

std::vector<std::string> exposure_warnings(const config::Config& config) {
  std::vector<std::string> out;
  if (config.web) web_exposure(*config.web, out);
  ascii_exposure(config.services.ascii, out);
  for (const auto& o : config.outputs) output_exposure(o, out);
  return out;
}

}  // namespace cobridge::app
