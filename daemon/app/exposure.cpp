#include "app/exposure.hpp"

#include "web/host_check.hpp"

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

void ascii_exposure(const config::AsciiGatewaySettings& a, std::vector<std::string>& out) {
  if (!a.enabled || a.tcp_port == 0 || is_loopback(a.bind)) return;
  const std::string here = a.where + ": [ascii_gateway] listens on " + a.bind + ":" + std::to_string(a.tcp_port);
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
  if (!bind || is_loopback(*bind)) return;
  const std::string here = o.where.to_string() + ": [outputs." + o.name + "] listens on " + *bind;
  out.push_back(here + " (non-loopback) without authentication: whoever reaches it reads every value");
  const toml::array* allow = t["write_allow"].as_array();
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
  ascii_exposure(config.remote.ascii, out);
  for (const auto& o : config.outputs) output_exposure(o, out);
  return out;
}

}  // namespace cobridge::app
