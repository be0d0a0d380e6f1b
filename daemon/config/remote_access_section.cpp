#include "config/remote_access_section.hpp"

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

void read_control(TableReader& top, DiagnosticSink& sink, ControlAccess& out) {
  const toml::table* t = top.subtable("control");
  if (t == nullptr) return;
  TableReader r(*t, "[control]", "", "control.", sink);
  r.check_keys({"writes_enabled", "write_group"});
  if (auto v = r.boolean("writes_enabled")) out.writes_enabled = *v;
  if (auto v = r.string("write_group")) out.write_group = *v;
  // A group nobody can be in would refuse every write but root's, silently:
  // checked when writes are on, the only time it is used.
  if (!out.writes_enabled || out.write_group.empty() || group_exists(out.write_group)) return;
  const toml::node* at = r.find("write_group") != nullptr ? r.find("write_group") : r.find("writes_enabled");
  r.error(*at, "control.write_group " + in_quotes(out.write_group) +
                   " is not a group on this machine (the package creates cobridge-admin; \"\" = anyone who may "
                   "connect)");
}

void read_ascii(TableReader& top, DiagnosticSink& sink, AsciiGatewaySettings& out) {
  const toml::table* t = top.subtable("ascii_gateway");
  if (t == nullptr) return;
  TableReader r(*t, "[ascii_gateway]", "", "ascii_gateway.", sink);
  r.check_keys({"enabled", "socket", "tcp_port", "bind", "writes_enabled", "max_clients", "sdo_timeout_ms"});
  out.enabled = true;
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
  if (auto v = r.integer("max_clients", 1, 1024)) out.max_clients = static_cast<std::uint32_t>(*v);
  if (auto v = r.integer("sdo_timeout_ms", 10, 60000)) out.sdo_timeout_ms = static_cast<std::uint32_t>(*v);
}

}  // namespace

void read_remote_access(TableReader& top, DiagnosticSink& sink, RemoteAccess& out) {
  read_control(top, sink, out.control);
  read_ascii(top, sink, out.ascii);
}

}  // namespace cobridge::config
