#include "dds/dds_config.hpp"

#include <toml++/toml.h>

#include <limits>

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
    if (k == "domain") {
      const auto* v = node.as_integer();
      if (v == nullptr) return fail(DdsConfigErrc::kWrongType, "'domain' must be an integer");
      if (v->get() < 0 || v->get() > kMaxDomain) {
        return fail(DdsConfigErrc::kOutOfRange, "'domain' must be 0.." + std::to_string(kMaxDomain));
      }
      r.config.domain = static_cast<std::uint32_t>(v->get());
    } else if (k == "sample_reliability") {
      const auto* v = node.as_string();
      if (v == nullptr) return fail(DdsConfigErrc::kWrongType, "'sample_reliability' must be a string");
      if (v->get() == "best-effort") {
        r.config.sample_reliability = Reliability::kBestEffort;
      } else if (v->get() == "reliable") {
        r.config.sample_reliability = Reliability::kReliable;
      } else {
        return fail(DdsConfigErrc::kOutOfRange,
                    "'sample_reliability' must be \"best-effort\" or \"reliable\", not \"" + v->get() + "\"");
      }
    } else if (k == "sample_depth") {
      const auto* v = node.as_integer();
      if (v == nullptr) return fail(DdsConfigErrc::kWrongType, "'sample_depth' must be an integer");
      if (v->get() < 1 || v->get() > kMaxDepth) {
        return fail(DdsConfigErrc::kOutOfRange, "'sample_depth' must be 1.." + std::to_string(kMaxDepth));
      }
      r.config.sample_depth = static_cast<std::int32_t>(v->get());
    } else if (k == "topic_prefix") {
      const auto* v = node.as_string();
      if (v == nullptr) return fail(DdsConfigErrc::kWrongType, "'topic_prefix' must be a string");
      r.config.topic_prefix = v->get();
    } else if (k == "partition") {
      const auto* v = node.as_string();
      if (v == nullptr) return fail(DdsConfigErrc::kWrongType, "'partition' must be a string");
      r.config.partition = v->get();
    } else if (k == "write_batch") {
      const auto* v = node.as_boolean();
      if (v == nullptr) return fail(DdsConfigErrc::kWrongType, "'write_batch' must be true or false");
      r.config.write_batch = v->get();
    } else if (k == "liveliness_lease_ms") {
      const auto* v = node.as_integer();
      if (v == nullptr) return fail(DdsConfigErrc::kWrongType, "'liveliness_lease_ms' must be an integer");
      if (v->get() < kMinLeaseMs || v->get() > kMaxLeaseMs) {
        return fail(DdsConfigErrc::kOutOfRange, "'liveliness_lease_ms' must be " + std::to_string(kMinLeaseMs) +
                                                    ".." + std::to_string(kMaxLeaseMs));
      }
      r.config.liveliness_lease_ms = v->get();
    } else if (k == "sample_path") {
      const auto* v = node.as_string();
      if (v == nullptr) return fail(DdsConfigErrc::kWrongType, "'sample_path' must be a string");
      if (v->get() == "auto") {
        r.config.sample_path = SamplePath::kAuto;
      } else if (v->get() == "dispatcher") {
        r.config.sample_path = SamplePath::kDispatcher;
      } else if (v->get() == "writer-thread") {
        r.config.sample_path = SamplePath::kWriterThread;
      } else {
        return fail(DdsConfigErrc::kOutOfRange,
                    "'sample_path' must be \"auto\", \"dispatcher\" or \"writer-thread\", not \"" + v->get() + "\"");
      }
    } else if (k == "security") {
      r = parse_security(node, std::move(r));
      if (!r.ok()) return r;
    } else {
      return fail(DdsConfigErrc::kUnknownKey,
                  "unknown key '" + std::string(k) + "' (expected " + std::string(kKnownKeys) + ")");
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
