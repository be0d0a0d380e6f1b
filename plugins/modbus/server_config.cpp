#include "server_config.hpp"

#include <toml++/toml.h>

#include <arpa/inet.h>

#include <array>
#include <cstdint>
#include <limits>

namespace cobridge::modbus {
namespace {

plugin::Error fail(ConfigErrc code, std::string message) { return {code, "config: " + std::move(message)}; }

// Integer key within [lo, hi].
plugin::Error get_int(const toml::node& node, std::string_view key, std::int64_t lo, std::int64_t hi,
                     std::int64_t& out) {
  const auto* v = node.as_integer();
  if (v == nullptr) return fail(ConfigErrc::kBadType, "'" + std::string(key) + "' must be an integer");
  if (v->get() < lo || v->get() > hi) {
    return fail(ConfigErrc::kBadValue, "'" + std::string(key) + "' = " + std::to_string(v->get()) +
                                           " is outside " + std::to_string(lo) + ".." + std::to_string(hi));
  }
  out = v->get();
  return {};
}

plugin::Error get_bool(const toml::node& node, std::string_view key, bool& out) {
  const auto* v = node.as_boolean();
  if (v == nullptr) return fail(ConfigErrc::kBadType, "'" + std::string(key) + "' must be a boolean");
  out = v->get();
  return {};
}

// `allow` / `write_allow`: an array of CIDR strings.
plugin::Error parse_networks(std::string_view key, const toml::node& node, IpAllowList& out) {
  const std::string k(key);
  const auto* a = node.as_array();
  if (a == nullptr) return fail(ConfigErrc::kBadType, "'" + k + "' must be an array of CIDR strings");
  for (const toml::node& e : *a) {
    const auto* s = e.as_string();
    if (s == nullptr) return fail(ConfigErrc::kBadType, "'" + k + "' entries must be strings");
    if (!out.add(s->get()))
      return fail(ConfigErrc::kBadValue, "'" + k + "' entry \"" + s->get() + "\" is not an address or CIDR network");
  }
  return {};
}

plugin::Error apply_key(std::string_view k, const toml::node& node, ServerConfig& c) {
  std::int64_t n = 0;
  plugin::Error r;
  if (k == "bind") {
    const auto* s = node.as_string();
    if (s == nullptr) return fail(ConfigErrc::kBadType, "'bind' must be a string");
    std::array<unsigned char, 16> buf{};
    if (inet_pton(AF_INET, s->get().c_str(), buf.data()) != 1 && inet_pton(AF_INET6, s->get().c_str(), buf.data()) != 1) {
      return fail(ConfigErrc::kBadValue, "'bind' = \"" + s->get() + "\" is not an IPv4 or IPv6 address");
    }
    c.bind = s->get();
  } else if (k == "port") {
    if ((r = get_int(node, k, 0, 65535, n))) return r;
    c.port = static_cast<std::uint16_t>(n);
  } else if (k == "max_clients") {
    if ((r = get_int(node, k, 1, 4096, n))) return r;
    c.max_clients = static_cast<std::uint32_t>(n);
  } else if (k == "idle_timeout_s") {
    if ((r = get_int(node, k, 0, 86400, n))) return r;
    c.idle_timeout_s = static_cast<std::uint32_t>(n);
  } else if (k == "first_request_timeout_ms") {
    if ((r = get_int(node, k, 0, 600000, n))) return r;
    c.first_request_timeout_ms = static_cast<std::uint32_t>(n);
  } else if (k == "unit_id") {
    if ((r = get_int(node, k, 0, 255, n))) return r;
    c.unit_id = static_cast<int>(n);
  } else if (k == "max_devices") {
    if ((r = get_int(node, k, 1, kMaxDeviceSlots, n))) return r;
    c.max_devices = static_cast<std::uint16_t>(n);
  } else if (k == "writes_enabled") {
    return get_bool(node, k, c.writes_enabled);
  } else if (k == "offline_exception") {
    return get_bool(node, k, c.offline_exception);
  } else if (k == "word_order") {
    const auto* s = node.as_string();
    if (s == nullptr) return fail(ConfigErrc::kBadType, "'word_order' must be a string");
    if (s->get() == "big") {
      c.word_order = WordOrder::kBig;
    } else if (s->get() == "little") {
      c.word_order = WordOrder::kLittle;
    } else {
      return fail(ConfigErrc::kBadValue, "'word_order' = \"" + s->get() + "\" (expected \"big\" or \"little\")");
    }
  } else if (k == "allow" || k == "write_allow") {
    return parse_networks(k, node, k == "allow" ? c.allow : c.write_allow);
  } else {
    return fail(ConfigErrc::kUnknownKey,
                "unknown key '" + std::string(k) +
                    "' (expected bind, port, max_clients, allow, write_allow, idle_timeout_s, first_request_timeout_ms, "
                    "unit_id, "
                    "word_order, "
                    "writes_enabled, offline_exception, max_devices)");
  }
  return {};
}

}  // namespace

plugin::Error parse_config(std::string_view toml_text, ServerConfig& out) {
  toml::table table;
  try {
    table = toml::parse(toml_text, std::string_view("modbus"));
  } catch (const toml::parse_error& e) {
    return fail(ConfigErrc::kSyntax,
                std::string(e.description()) + " at line " + std::to_string(e.source().begin.line));
  }
  ServerConfig c;
  for (const auto& [key, node] : table) {
    if (plugin::Error r = apply_key(key.str(), node, c)) return r;
  }
  out = std::move(c);
  return {};
}

}  // namespace cobridge::modbus
