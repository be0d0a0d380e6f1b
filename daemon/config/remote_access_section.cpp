#include "config/remote_access_section.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>

namespace cobridge::config {
namespace {

void read_control(TableReader& top, DiagnosticSink& sink, ControlAccess& out) {
  const toml::table* t = top.subtable("control");
  if (t == nullptr) return;
  TableReader r(*t, "[control]", "", "control.", sink);
  r.check_keys({"writes_enabled", "write_group"});
  if (auto v = r.boolean("writes_enabled")) out.writes_enabled = *v;
  if (auto v = r.string("write_group")) out.write_group = *v;
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
