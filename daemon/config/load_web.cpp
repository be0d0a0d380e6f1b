// [web]: the HTTP status service.
#include "config/host_name.hpp"
#include "config/loader.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <map>
#include <system_error>

namespace cobridge::config::detail {
namespace {

// web.hosts: DNS names or IP literals, no port, kept canonical.
void read_hosts(TableReader& r, DiagnosticSink& sink, WebSettings& w) {
  const toml::node* n = r.find("hosts");
  if (n == nullptr) return;
  w.hosts_at = location(sink, *n);
  const toml::array* a = n->as_array();
  if (a == nullptr) {
    r.error(*n, "web.hosts must be an array of host names (e.g. [\"gw1.plant.local\", \"10.1.2.3\"])");
    return;
  }
  w.hosts.emplace();
  for (const toml::node& e : *a) {
    const auto* s = e.as_string();
    const auto host = s != nullptr ? canonical_host(s->get()) : std::nullopt;
    if (!host) {
      r.error(e, "web.hosts entry " + (s ? in_quotes(s->get()) : std::string("(not a string)")) +
                     " is not a host name or IP address (a name as clients type it, without scheme or port)");
      continue;
    }
    w.hosts->push_back(*host);
  }
}

}  // namespace

// ---- [web] -------------------------------------------------------------

void Loader::read_web(TableReader& top) {
  const toml::table* t = top.subtable("web");
  if (t == nullptr) return;
  TableReader r(*t, "[web]", "", "web.", sink_);
  r.check_keys({"enabled", "bind", "port", "tls_cert", "tls_key", "auth_file", "max_clients", "timeout_s", "hosts"});
  WebSettings w;
  w.where = location(sink_, *t);
  if (auto v = r.boolean("enabled")) w.enabled = *v;
  if (auto v = r.string("bind")) {
    in6_addr a6{};
    in_addr a4{};
    if (::inet_pton(AF_INET, v->c_str(), &a4) == 1 || ::inet_pton(AF_INET6, v->c_str(), &a6) == 1) {
      w.bind = *v;
    } else {
      r.error(*r.find("bind"), "web.bind " + in_quotes(*v) +
                                   " is not an IP address (e.g. \"127.0.0.1\", \"0.0.0.0\", \"::1\")");
    }
  }
  if (auto v = r.integer("port", 1, 65535)) w.port = static_cast<std::uint16_t>(*v);
  if (auto v = r.integer("max_clients", 1, 1024)) w.max_clients = static_cast<std::uint32_t>(*v);
  if (auto v = r.integer("timeout_s", 1, 3600)) w.timeout_s = static_cast<std::uint32_t>(*v);
  auto file = [&](std::string_view key, fs::path& out, SourceLocation& at) {
    const auto v = r.string(key);
    if (!v) return;
    at = location(sink_, *r.find(key));
    if (v->empty()) {
      r.error(*r.find(key), r.path(key) + " must name a file, got \"\"");
      return;
    }
    out = resolve(*v);
  };
  file("tls_cert", w.tls_cert, w.tls_cert_at);
  file("tls_key", w.tls_key, w.tls_key_at);
  file("auth_file", w.auth_file, w.auth_file_at);
  read_hosts(r, sink_, w);
  if (w.tls_cert.empty() != w.tls_key.empty()) {
    const bool has_cert = !w.tls_cert.empty();
    r.error(*r.find(has_cert ? "tls_cert" : "tls_key"),
            std::string("web.") + (has_cert ? "tls_cert" : "tls_key") + " is set but web." +
                (has_cert ? "tls_key" : "tls_cert") + " is not (TLS needs both)");
  }
  config_.web = std::move(w);
}

}  // namespace cobridge::config::detail
