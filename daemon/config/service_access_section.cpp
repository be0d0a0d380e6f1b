#include "config/service_access_section.hpp"

#include "config/loader.hpp"

#include <cobridge/ip_allow_list.hpp>

#include <arpa/inet.h>
#include <grp.h>
#include <netinet/in.h>

#include <vector>

namespace cobridge::config {
namespace {

bool group_exists(const std::string& name) {
  // getgrnam_r: the loader may run beside the web thread (SIGHUP reload).
  group g{};
  group* found = nullptr;
  std::vector<char> buf(16384);
  return ::getgrnam_r(name.c_str(), &g, buf.data(), buf.size(), &found) == 0 && found != nullptr;
}

// A group nobody can be in would refuse every write but root's, silently:
// checked when writes are on, the only time it is used.
void check_write_group(TableReader& r, const char* table, bool writes_enabled, const std::string& group) {
  if (!writes_enabled || group.empty() || group_exists(group)) return;
  const toml::node* at = r.find("write_group") != nullptr ? r.find("write_group") : r.find("writes_enabled");
  r.error(*at, std::string(table) + ".write_group " + in_quotes(group) +
                   " is not a group on this machine (the package creates cobridge-admin; \"\" = anyone who may "
                   "connect)");
}

void read_control(TableReader& top, DiagnosticSink& sink, ControlAccess& out) {
  const toml::table* t = top.subtable("control");
  if (t == nullptr) return;
  TableReader r(*t, "[control]", "", "control.", sink);
  r.check_keys({"writes_enabled", "write_group"});
  if (auto v = r.boolean("writes_enabled")) out.writes_enabled = *v;
  if (auto v = r.string("write_group")) out.write_group = *v;
  check_write_group(r, "control", out.writes_enabled, out.write_group);
}

// ascii_gateway.write_allow: CIDR strings, checked as the listener will match them.
void read_write_allow(TableReader& r, std::vector<std::string>& out) {
  const toml::node* n = r.find("write_allow");
  if (n == nullptr) return;
  const toml::array* a = n->as_array();
  if (a == nullptr) {
    r.error(*n, "ascii_gateway.write_allow must be an array of CIDR strings (e.g. [\"10.1.0.0/16\"])");
    return;
  }
  for (const toml::node& e : *a) {
    IpAllowList check;
    const auto* s = e.as_string();
    if (s == nullptr || !check.add(s->get())) {
      r.error(e, "ascii_gateway.write_allow entry " + (s ? in_quotes(s->get()) : std::string("(not a string)")) +
                     " is not an address or CIDR network");
      continue;
    }
    out.push_back(s->get());
  }
}

void read_ascii(TableReader& top, DiagnosticSink& sink, AsciiGatewaySettings& out) {
  const toml::table* t = top.subtable("ascii_gateway");
  if (t == nullptr) return;
  TableReader r(*t, "[ascii_gateway]", "", "ascii_gateway.", sink);
  r.check_keys({"enabled", "socket", "tcp_port", "bind", "writes_enabled", "write_allow", "write_group", "max_clients",
                "sdo_timeout_ms"});
  out.enabled = true;
  out.where = detail::location(sink, *t).to_string();
  if (auto v = r.boolean("enabled")) out.enabled = *v;
  if (auto v = r.string("socket")) {
    if (v->empty() || v->front() != '/') {
      r.error(*r.find("socket"), "ascii_gateway.socket " + in_quotes(*v) + " must be an absolute path");
    } else {
      out.socket = *v;
    }
  }
  if (auto v = r.integer("tcp_port", 0, 65535)) out.tcp_port = static_cast<std::uint16_t>(*v);
  if (auto v = r.string("bind")) {
    in_addr a4{};
    if (::inet_pton(AF_INET, v->c_str(), &a4) == 1) {
      out.bind = *v;
    } else {
      r.error(*r.find("bind"), "ascii_gateway.bind " + in_quotes(*v) + " is not an IPv4 address (e.g. \"127.0.0.1\")");
    }
  }
  if (auto v = r.boolean("writes_enabled")) out.writes_enabled = *v;
  read_write_allow(r, out.write_allow);
  if (auto v = r.string("write_group")) out.write_group = *v;
  check_write_group(r, "ascii_gateway", out.writes_enabled, out.write_group);
  if (auto v = r.integer("max_clients", 1, 1024)) out.max_clients = static_cast<std::uint32_t>(*v);
  if (auto v = r.integer("sdo_timeout_ms", 10, 60000)) out.sdo_timeout_ms = static_cast<std::uint32_t>(*v);
}

}  // namespace

void read_service_access(TableReader& top, DiagnosticSink& sink, ServiceAccess& out) {
  read_control(top, sink, out.control);
  read_ascii(top, sink, out.ascii);
}

}  // namespace cobridge::config
