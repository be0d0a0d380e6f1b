#include "dds/dds_config.hpp"

#include <toml++/toml.h>

#include <limits>
#include <utility>

namespace cobridge::dds {
namespace {

// The default DDSI port mapping (PB 7400, DG 250) fits domains 0..232 into
// the 16-bit UDP port range.
constexpr std::int64_t kMaxDomain = 232;
// Writer history beyond this only costs memory: a late sample is useless.
constexpr std::int64_t kMaxDepth = 10000;
// Below 100 ms the participant's liveliness messages become traffic of their
// own; above 1 h a dead gateway is as good as never detected.
constexpr std::int64_t kMinLeaseMs = 100, kMaxLeaseMs = 3'600'000;
constexpr std::string_view kKnownKeys =
    "domain, sample_reliability, sample_depth, topic_prefix, partition, write_batch, liveliness_lease_ms, "
    "sample_path, security";

DdsConfigResult fail(plugin::Error e) {
  DdsConfigResult r;
  r.error = plugin::Error(e.code, "config: " + e.to_string());
  return r;
}

DdsConfigResult fail(DdsConfigErrc code, std::string message) { return fail(plugin::Error(code, std::move(message))); }

// One key of [security]: a non-empty absolute path. Absolute because the
// plugin is given its table, not the configuration file's folder.
plugin::Error read_path(std::string_view key, const toml::node& node, std::string& out) {
  const auto* v = node.as_string();
  if (v == nullptr)
    return {DdsConfigErrc::kWrongType, "'security." + std::string(key) + "' must be a string (a file path)"};
  if (v->get().empty() || v->get().front() != '/') {
    return {DdsConfigErrc::kOutOfRange,
            "'security." + std::string(key) + "' must be an absolute path, not \"" + v->get() + "\""};
  }
  out = v->get();
  return {};
}

// [security]: the six files, all or none (a table without them all is a
// mistake, never a quiet fallback to an open DDS), then checked on disk.
DdsConfigResult parse_security(const toml::node& node, DdsConfigResult r) {
  const auto* table = node.as_table();
  if (table == nullptr) return fail(DdsConfigErrc::kWrongType, "'security' must be a table ([outputs.dds.security])");
  DdsSecurity s;
  for (const auto& [key, value] : *table) {
    const std::string_view k = key.str();
    std::string* target = k == "plugin_dir" ? &s.plugin_dir : nullptr;
    for (const SecurityFileKey& f : kSecurityFileKeys)
      if (k == f.key) target = &(s.*f.member);
    if (target == nullptr) {
      return fail(DdsConfigErrc::kUnknownKey, "unknown key 'security." + std::string(k) +
                                                  "' (expected identity_ca, identity_certificate, private_key, "
                                                  "permissions_ca, governance, permissions, plugin_dir)");
    }
    if (plugin::Error e = read_path(k, value, *target)) return fail(std::move(e));
  }
  std::string missing;
  for (const SecurityFileKey& f : kSecurityFileKeys)
    if ((s.*f.member).empty()) missing += (missing.empty() ? "'security." : ", 'security.") + std::string(f.key) + "'";
  if (!missing.empty()) {
    return fail(DdsConfigErrc::kMissingKey, "DDS Security needs all six files, missing " + missing +
                                                " (leave out [outputs.dds.security] for an open DDS)");
  }
  if (plugin::Error e = check_security(s)) return fail(std::move(e));
  r.config.security = std::move(s);
  return r;
}

// An integer key within min..max.
plugin::Error read_integer(std::string_view key, const toml::node& node, std::int64_t min, std::int64_t max,
                           std::int64_t& out) {
  const auto* v = node.as_integer();
  if (v == nullptr) return {DdsConfigErrc::kWrongType, "'" + std::string(key) + "' must be an integer"};
  if (v->get() < min || v->get() > max) {
    return {DdsConfigErrc::kOutOfRange,
            "'" + std::string(key) + "' must be " + std::to_string(min) + ".." + std::to_string(max)};
  }
  out = v->get();
  return {};
}

plugin::Error read_string(std::string_view key, const toml::node& node, std::string& out) {
  const auto* v = node.as_string();
  if (v == nullptr) return {DdsConfigErrc::kWrongType, "'" + std::string(key) + "' must be a string"};
  out = v->get();
  return {};
}

// A string key that names one of `choices`; `allowed` lists them for the
// message.
template <typename Enum, std::size_t N>
plugin::Error read_choice(std::string_view key, const toml::node& node,
                          const std::pair<std::string_view, Enum> (&choices)[N], std::string_view allowed, Enum& out) {
  std::string text;
  if (plugin::Error e = read_string(key, node, text)) return e;
  for (const auto& [name, value] : choices) {
    if (name == text) {
      out = value;
      return {};
    }
  }
  return {DdsConfigErrc::kOutOfRange,
          "'" + std::string(key) + "' must be " + std::string(allowed) + ", not \"" + text + "\""};
}

constexpr std::pair<std::string_view, Reliability> kReliabilities[] = {
    {"best-effort", Reliability::kBestEffort}, {"reliable", Reliability::kReliable}};
constexpr std::pair<std::string_view, SamplePath> kSamplePaths[] = {
    {"auto", SamplePath::kAuto}, {"dispatcher", SamplePath::kDispatcher}, {"writer-thread", SamplePath::kWriterThread}};

// One top-level key other than [security].
plugin::Error read_key(std::string_view k, const toml::node& node, DdsConfig& c) {
  std::int64_t n = 0;
  plugin::Error e;
  if (k == "domain") {
    if (!(e = read_integer(k, node, 0, kMaxDomain, n))) c.domain = static_cast<std::uint32_t>(n);
  } else if (k == "sample_reliability") {
    e = read_choice(k, node, kReliabilities, R"("best-effort" or "reliable")", c.sample_reliability);
  } else if (k == "sample_depth") {
    if (!(e = read_integer(k, node, 1, kMaxDepth, n))) c.sample_depth = static_cast<std::int32_t>(n);
  } else if (k == "topic_prefix") {
    e = read_string(k, node, c.topic_prefix);
  } else if (k == "partition") {
    e = read_string(k, node, c.partition);
  } else if (k == "write_batch") {
    const auto* v = node.as_boolean();
    if (v == nullptr) return {DdsConfigErrc::kWrongType, "'write_batch' must be true or false"};
    c.write_batch = v->get();
  } else if (k == "liveliness_lease_ms") {
    if (!(e = read_integer(k, node, kMinLeaseMs, kMaxLeaseMs, n))) c.liveliness_lease_ms = n;
  } else if (k == "sample_path") {
    e = read_choice(k, node, kSamplePaths, R"("auto", "dispatcher" or "writer-thread")", c.sample_path);
  } else {
    return {DdsConfigErrc::kUnknownKey,
            "unknown key '" + std::string(k) + "' (expected " + std::string(kKnownKeys) + ")"};
  }
  return e;
}

}  // namespace

std::string_view to_string(Reliability r) noexcept {
  return r == Reliability::kReliable ? "reliable" : "best-effort";
}

DdsConfigResult parse_dds_config(std::string_view toml_text) {
  toml::table table;
  try {
    table = toml::parse(toml_text, std::string_view("dds"));
  } catch (const toml::parse_error& e) {
    return fail(DdsConfigErrc::kSyntax,
                std::string(e.description()) + " at line " + std::to_string(e.source().begin.line));
  }
  DdsConfigResult r;
  for (const auto& [key, node] : table) {
    const std::string_view k = key.str();
    if (k == "security") {
      r = parse_security(node, std::move(r));
      if (!r.ok()) return r;
    } else if (plugin::Error e = read_key(k, node, r.config)) {
      return fail(std::move(e));
    }
  }
  return r;
}

std::string_view to_string(SamplePath p) noexcept {
  switch (p) {
    case SamplePath::kAuto: return "auto";
    case SamplePath::kDispatcher: return "dispatcher";
    case SamplePath::kWriterThread: return "writer-thread";
  }
  return "?";
}

}  // namespace cobridge::dds
