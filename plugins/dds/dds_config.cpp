#include "dds/dds_config.hpp"

#include <toml++/toml.h>

#include <limits>
#include <utility>

namespace cobridge::dds {
namespace {

class ConfigCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "cobridge.dds.config"; }
  std::string message(int c) const override {
    switch (static_cast<DdsConfigErrc>(c)) {
      case DdsConfigErrc::kSyntax: return "not valid TOML";
      case DdsConfigErrc::kUnknownKey: return "unknown key";
      case DdsConfigErrc::kWrongType: return "wrong value type";
      case DdsConfigErrc::kOutOfRange: return "value out of range";
      case DdsConfigErrc::kMissingKey: return "required key missing";
      case DdsConfigErrc::kBadFile: return "file cannot be used";
    }
    return "unknown error";
  }
};

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

DdsConfigResult fail(DdsConfigErrc code, std::string message) {
  DdsConfigResult r;
  r.error = make_error_code(code);
  r.message = "config: " + std::move(message);
  return r;
}

DdsConfigResult fail(std::error_code ec, std::string message) {
  DdsConfigResult r;
  r.error = ec;
  r.message = "config: " + std::move(message);
  return r;
}

// One key of [security]: a non-empty absolute path. Absolute because the
// plugin is given its table, not the configuration file's folder.
std::error_code read_path(std::string_view key, const toml::node& node, std::string& out, std::string& message) {
  const auto* v = node.as_string();
  if (v == nullptr) {
    message = "'security." + std::string(key) + "' must be a string (a file path)";
    return make_error_code(DdsConfigErrc::kWrongType);
  }
  if (v->get().empty() || v->get().front() != '/') {
    message = "'security." + std::string(key) + "' must be an absolute path, not \"" + v->get() + "\"";
    return make_error_code(DdsConfigErrc::kOutOfRange);
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
  std::string message;
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
    if (const std::error_code ec = read_path(k, value, *target, message)) return fail(ec, message);
  }
  std::string missing;
  for (const SecurityFileKey& f : kSecurityFileKeys)
    if ((s.*f.member).empty()) missing += (missing.empty() ? "'security." : ", 'security.") + std::string(f.key) + "'";
  if (!missing.empty()) {
    return fail(DdsConfigErrc::kMissingKey, "DDS Security needs all six files, missing " + missing +
                                                " (leave out [outputs.dds.security] for an open DDS)");
  }
  if (const std::error_code ec = check_security(s, message)) return fail(ec, message);
  r.config.security = std::move(s);
  return r;
}

// An integer key within min..max.
std::error_code read_integer(std::string_view key, const toml::node& node, std::int64_t min, std::int64_t max,
                             std::int64_t& out, std::string& message) {
  const auto* v = node.as_integer();
  if (v == nullptr) {
    message = "'" + std::string(key) + "' must be an integer";
    return make_error_code(DdsConfigErrc::kWrongType);
  }
  if (v->get() < min || v->get() > max) {
    message = "'" + std::string(key) + "' must be " + std::to_string(min) + ".." + std::to_string(max);
    return make_error_code(DdsConfigErrc::kOutOfRange);
  }
  out = v->get();
  return {};
}

std::error_code read_string(std::string_view key, const toml::node& node, std::string& out, std::string& message) {
  const auto* v = node.as_string();
  if (v == nullptr) {
    message = "'" + std::string(key) + "' must be a string";
    return make_error_code(DdsConfigErrc::kWrongType);
  }
  out = v->get();
  return {};
}

// A string key that names one of `choices`; `allowed` lists them for the
// message.
template <typename Enum, std::size_t N>
std::error_code read_choice(std::string_view key, const toml::node& node,
                            const std::pair<std::string_view, Enum> (&choices)[N], std::string_view allowed,
                            Enum& out, std::string& message) {
  std::string text;
  if (const std::error_code ec = read_string(key, node, text, message)) return ec;
  for (const auto& [name, value] : choices) {
    if (name == text) {
      out = value;
      return {};
    }
  }
  message = "'" + std::string(key) + "' must be " + std::string(allowed) + ", not \"" + text + "\"";
  return make_error_code(DdsConfigErrc::kOutOfRange);
}

constexpr std::pair<std::string_view, Reliability> kReliabilities[] = {
    {"best-effort", Reliability::kBestEffort}, {"reliable", Reliability::kReliable}};
constexpr std::pair<std::string_view, SamplePath> kSamplePaths[] = {
    {"auto", SamplePath::kAuto}, {"dispatcher", SamplePath::kDispatcher}, {"writer-thread", SamplePath::kWriterThread}};

// One top-level key other than [security].
std::error_code read_key(std::string_view k, const toml::node& node, DdsConfig& c, std::string& message) {
  std::int64_t n = 0;
  std::error_code ec;
  if (k == "domain") {
    if (!(ec = read_integer(k, node, 0, kMaxDomain, n, message))) c.domain = static_cast<std::uint32_t>(n);
  } else if (k == "sample_reliability") {
    ec = read_choice(k, node, kReliabilities, R"("best-effort" or "reliable")", c.sample_reliability, message);
  } else if (k == "sample_depth") {
    if (!(ec = read_integer(k, node, 1, kMaxDepth, n, message))) c.sample_depth = static_cast<std::int32_t>(n);
  } else if (k == "topic_prefix") {
    ec = read_string(k, node, c.topic_prefix, message);
  } else if (k == "partition") {
    ec = read_string(k, node, c.partition, message);
  } else if (k == "write_batch") {
    const auto* v = node.as_boolean();
    if (v == nullptr) {
      message = "'write_batch' must be true or false";
      return make_error_code(DdsConfigErrc::kWrongType);
    }
    c.write_batch = v->get();
  } else if (k == "liveliness_lease_ms") {
    if (!(ec = read_integer(k, node, kMinLeaseMs, kMaxLeaseMs, n, message))) c.liveliness_lease_ms = n;
  } else if (k == "sample_path") {
    ec = read_choice(k, node, kSamplePaths, R"("auto", "dispatcher" or "writer-thread")", c.sample_path, message);
  } else {
    message = "unknown key '" + std::string(k) + "' (expected " + std::string(kKnownKeys) + ")";
    return make_error_code(DdsConfigErrc::kUnknownKey);
  }
  return ec;
}

}  // namespace

const std::error_category& dds_config_category() noexcept {
  static const ConfigCategory category;
  return category;
}

std::error_code make_error_code(DdsConfigErrc e) noexcept { return {static_cast<int>(e), dds_config_category()}; }

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
  std::string message;
  for (const auto& [key, node] : table) {
    const std::string_view k = key.str();
    if (k == "security") {
      r = parse_security(node, std::move(r));
      if (!r.ok()) return r;
    } else if (const std::error_code ec = read_key(k, node, r.config, message)) {
      return fail(ec, message);
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
