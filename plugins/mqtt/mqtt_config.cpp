#include "mqtt_config.hpp"

#include "sparkplug_metrics.hpp"

#include <toml++/toml.h>

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <optional>

namespace cobridge::mqtt {
namespace {

using plugin::ConfigErrc;

plugin::Error fail(ConfigErrc code, const std::string& key, const std::string& why) {
  return {code, "config: '" + key + "' " + why, key};
}

plugin::Error get_string(const toml::node& node, const std::string& key, std::string& out) {
  const auto* s = node.as_string();
  if (s == nullptr) return fail(ConfigErrc::kWrongType, key, "must be a string");
  if (s->get().empty()) return fail(ConfigErrc::kOutOfRange, key, "is empty");
  out = s->get();
  return {};
}

plugin::Error get_int(const toml::node& node, const std::string& key, std::int64_t lo, std::int64_t hi,
                      std::int64_t& out) {
  const auto* v = node.as_integer();
  if (v == nullptr) return fail(ConfigErrc::kWrongType, key, "must be an integer");
  if (v->get() < lo || v->get() > hi)
    return fail(ConfigErrc::kOutOfRange, key,
                "= " + std::to_string(v->get()) + " is outside " + std::to_string(lo) + ".." + std::to_string(hi));
  out = v->get();
  return {};
}

plugin::Error get_id(const toml::node& node, const std::string& key, std::string& out) {
  if (plugin::Error e = get_string(node, key, out)) return e;
  if (!valid_sparkplug_id(out)) return fail(ConfigErrc::kOutOfRange, key, "may not contain '/', '+' or '#'");
  return {};
}

// A file named by a key must exist and be readable now (checked at load,
// not at the first connect).
plugin::Error get_file(const toml::node& node, const std::string& key, std::string& out) {
  if (plugin::Error e = get_string(node, key, out)) return e;
  struct stat st {};
  if (::stat(out.c_str(), &st) != 0)
    return fail(ConfigErrc::kBadFile, key, "= \"" + out + "\": " + std::strerror(errno));
  if (!S_ISREG(st.st_mode)) return fail(ConfigErrc::kBadFile, key, "= \"" + out + "\" is not a regular file");
  return {};
}

// bdseq_file: "" (in memory only) or a path whose folder exists now.
plugin::Error get_bdseq_file(const toml::node& node, MqttConfig& c) {
  const std::string key = "bdseq_file";
  const auto* s = node.as_string();
  if (s == nullptr) return fail(ConfigErrc::kWrongType, key, "must be a string (a file path, or \"\" for none)");
  c.bdseq_file = s->get();
  c.bdseq_file_set = true;
  if (c.bdseq_file.empty()) return {};
  const std::size_t slash = c.bdseq_file.rfind('/');
  const std::string folder = slash == std::string::npos ? "." : (slash == 0 ? "/" : c.bdseq_file.substr(0, slash));
  struct stat st {};
  if (::stat(folder.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
    return fail(ConfigErrc::kBadFile, key, "= \"" + c.bdseq_file + "\": its folder " + folder + " does not exist");
  return {};
}

// The password file: owner-only (no group/other bits), its first line.
plugin::Error read_password(const std::string& path, std::string& out) {
  const std::string key = "password_file";
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    return fail(ConfigErrc::kBadFile, key, "= \"" + path + "\": " + std::strerror(errno));
  if ((st.st_mode & 077) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    return fail(ConfigErrc::kBadFile, key,
                "= \"" + path + "\" has mode " + mode + ": it must be readable by its owner only (chmod 600)");
  }
  std::ifstream in(path);
  if (!in) return fail(ConfigErrc::kBadFile, key, "= \"" + path + "\" cannot be read");
  std::getline(in, out);
  if (!out.empty() && out.back() == '\r') out.pop_back();
  if (out.empty()) return fail(ConfigErrc::kBadFile, key, "= \"" + path + "\" holds no password on its first line");
  return {};
}

plugin::Error parse_deadband(const toml::node& node, MqttConfig& c) {
  const auto* t = node.as_table();
  if (t == nullptr) return fail(ConfigErrc::kWrongType, "deadband", "must be a table of metric name = number");
  for (const auto& [k, v] : *t) {
    const std::string name(k.str());
    const std::string key = "deadband." + name;
    const MetricDef* def = nullptr;
    for (const auto& d : process_metrics())
      if (name == d.name) def = &d;
    if (def == nullptr) return fail(ConfigErrc::kUnknownKey, key, "names no metric (see docs/mqtt.md, metric table)");
    const std::optional<double> value = v.value<double>();
    if (!value || *value < 0.0) return fail(ConfigErrc::kOutOfRange, key, "must be a number >= 0");
    c.deadband[process_index(def->id)] = *value;
  }
  return {};
}

// metrics: a table of device name (or "*") = array of process metric names.
plugin::Error parse_metric_sets(const toml::node& node, MetricSets& out) {
  const auto* t = node.as_table();
  if (t == nullptr)
    return fail(ConfigErrc::kWrongType, "metrics", "must be a table of device name (or \"*\") = [metric names]");
  for (const auto& [k, v] : *t) {
    const std::string key = "metrics." + std::string(k.str());
    const auto* a = v.as_array();
    if (a == nullptr || a->empty())
      return fail(ConfigErrc::kWrongType, key, "must be a non-empty array of metric names");
    std::uint32_t mask = 0;
    for (std::size_t i = 0; i < a->size(); ++i) {
      const std::string at = key + "[" + std::to_string(i) + "]";
      const auto* name = a->get(i)->as_string();
      if (name == nullptr) return fail(ConfigErrc::kWrongType, at, "must be a string");
      const MetricDef* def = nullptr;
      for (const auto& d : process_metrics())
        if (name->get() == d.name) def = &d;
      if (def == nullptr)
        return fail(ConfigErrc::kUnknownKey, at, "= \"" + name->get() + "\" names no process metric (see docs/mqtt.md, metric table)");
      mask |= 1u << process_index(def->id);
    }
    out.sets.emplace_back(std::string(k.str()), mask);
  }
  return {};
}

plugin::Error get_bool(const toml::node& node, const std::string& key, bool& out) {
  const auto* b = node.as_boolean();
  if (b == nullptr) return fail(ConfigErrc::kWrongType, key, "must be true or false");
  out = b->get();
  return {};
}

// write_allow: an array of "<device>", "<device>:<command>" or "*:<command>".
plugin::Error parse_write_allow(const toml::node& node, std::vector<WriteRule>& out) {
  const std::string key = "write_allow";
  const auto* a = node.as_array();
  if (a == nullptr) return fail(ConfigErrc::kWrongType, key, "must be an array of strings");
  for (std::size_t i = 0; i < a->size(); ++i) {
    const std::string at = key + "[" + std::to_string(i) + "]";
    const auto* s = a->get(i)->as_string();
    if (s == nullptr) return fail(ConfigErrc::kWrongType, at, "must be a string");
    WriteRule rule;
    const std::string why = parse_write_rule(s->get(), rule);
    if (!why.empty()) return fail(ConfigErrc::kOutOfRange, at, "= \"" + s->get() + "\" " + why);
    out.push_back(std::move(rule));
  }
  return {};
}

plugin::Error apply_key(const std::string& k, const toml::node& node, MqttConfig& c, std::string& password_file) {
  std::int64_t n = 0;
  if (k == "host") return get_string(node, k, c.host);
  if (k == "client_id") return get_string(node, k, c.client_id);
  if (k == "group_id") return get_id(node, k, c.group_id);
  if (k == "edge_node_id") return get_id(node, k, c.edge_node_id);
  if (k == "primary_host_id") return get_id(node, k, c.primary_host_id);
  if (k == "username") return get_string(node, k, c.username);
  if (k == "password_file") return get_string(node, k, password_file);
  if (k == "ca_file") return get_file(node, k, c.ca_file);
  if (k == "cert_file") return get_file(node, k, c.cert_file);
  if (k == "key_file") return get_file(node, k, c.key_file);
  if (k == "deadband") return parse_deadband(node, c);
  if (k == "metrics") return parse_metric_sets(node, c.metrics);
  if (k == "bdseq_file") return get_bdseq_file(node, c);
  if (k == "writes_enabled") return get_bool(node, k, c.writes.enabled);
  if (k == "write_allow") return parse_write_allow(node, c.writes.allow);
  if (k == "password") return fail(ConfigErrc::kUnknownKey, k, "is not taken: put the password in password_file (mode 0600)");
  plugin::Error e;
  if (k == "port") {
    if (!(e = get_int(node, k, 1, 65535, n))) c.port = static_cast<std::uint16_t>(n);
  } else if (k == "keepalive_s") {
    if (!(e = get_int(node, k, 5, 65535, n))) c.keepalive_s = static_cast<std::uint32_t>(n);
  } else if (k == "store_seconds") {
    if (!(e = get_int(node, k, 0, 3600, n))) c.store_seconds = static_cast<std::uint32_t>(n);
  } else if (k == "store_rate") {
    if (!(e = get_int(node, k, 1, 10000, n))) c.store_rate = static_cast<std::uint32_t>(n);
  } else if (k == "batch_samples") {
    if (!(e = get_int(node, k, 0, 1024, n))) c.batch_samples = static_cast<std::uint32_t>(n);
  } else if (k == "queue_depth") {
    if (!(e = get_int(node, k, 64, 1 << 20, n))) c.queue_depth = static_cast<std::uint32_t>(n);
  } else {
    e = fail(ConfigErrc::kUnknownKey, k,
             "is not a key of [outputs.mqtt] (host, port, client_id, group_id, edge_node_id, keepalive_s, username, "
             "password_file, ca_file, cert_file, key_file, primary_host_id, queue_depth, batch_samples, store_seconds, "
             "store_rate, "
             "bdseq_file, writes_enabled, write_allow, deadband, metrics)");
  }
  return e;
}

// Keys that only make sense together.
plugin::Error check_combinations(const MqttConfig& c, const std::string& password_file) {
  if (!password_file.empty() && c.username.empty())
    return fail(ConfigErrc::kMissingKey, "username", "is required with password_file");
  if (c.cert_file.empty() != c.key_file.empty())
    return fail(ConfigErrc::kMissingKey, c.cert_file.empty() ? "cert_file" : "key_file",
                "is required with " + std::string(c.cert_file.empty() ? "key_file" : "cert_file"));
  if (!c.cert_file.empty() && c.ca_file.empty())
    return fail(ConfigErrc::kMissingKey, "ca_file", "is required with cert_file and key_file (TLS)");
  if (c.edge_node_id.empty())
    return fail(ConfigErrc::kMissingKey, "edge_node_id", "is required (the gateway id is not a valid Sparkplug id)");
  return {};
}

}  // namespace

bool is_loopback_host(std::string_view host) noexcept {
  if (host == "localhost" || host == "::1" || host == "[::1]") return true;
  if (!host.starts_with("127.")) return false;
  // 127.a.b.c with digits and dots only (a name like "127.example.com" is not loopback).
  return host.find_first_not_of("0123456789.") == std::string_view::npos;
}

std::string plaintext_warning(const MqttConfig& c) {
  if (c.tls() || is_loopback_host(c.host)) return {};
  return "config: 'host' = \"" + c.host + "\" is not loopback and 'ca_file' is not set: the MQTT connection is "
         "plaintext, so the broker credentials, the data and the DCMD commands travel readable on the network "
         "(set ca_file for TLS)";
}

bool valid_sparkplug_id(std::string_view id) noexcept {
  return !id.empty() && id.find_first_of("/+#") == std::string_view::npos;
}

plugin::Error parse_config(std::string_view text, std::string_view gateway_id, MqttConfig& out) {
  toml::table table;
  try {
    table = toml::parse(text, std::string_view("mqtt"));
  } catch (const toml::parse_error& e) {
    return {ConfigErrc::kSyntax,
            "config: " + std::string(e.description()) + " at line " + std::to_string(e.source().begin.line)};
  }
  MqttConfig c;
  if (valid_sparkplug_id(gateway_id)) c.edge_node_id = std::string(gateway_id);
  std::string password_file;
  plugin::Error error;
  table.for_each([&](const toml::key& key, const auto& value) {
    if (!error) error = apply_key(std::string(key.str()), value, c, password_file);
  });
  if (!error) error = check_combinations(c, password_file);
  if (!error && !password_file.empty()) error = read_password(password_file, c.password);
  if (error) return error;
  if (c.client_id.empty()) c.client_id = "cobridge-" + c.edge_node_id;
  // The packaged state directory (StateDirectory=cobridge); another
  // [gateway] state_dir needs bdseq_file set to match.
  if (!c.bdseq_file_set) c.bdseq_file = "/var/lib/cobridge/mqtt-" + c.edge_node_id + ".bdseq";
  out = std::move(c);
  return {};
}

}  // namespace cobridge::mqtt
