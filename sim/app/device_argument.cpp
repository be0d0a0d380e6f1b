#include "app/device_argument.hpp"

#include "app/number_text.hpp"
#include "encoder/motion.hpp"
#include "families/family_traits.hpp"

#include <array>
#include <optional>
#include <string>

namespace cobridge::sim {

namespace {

std::string quoted(std::string_view s) { return "'" + std::string(s) + "'"; }

std::string rate_list(FamilyId family) {
  std::string out;
  for (const std::uint16_t r : family_bit_rates(family)) {
    if (!out.empty()) out += '|';
    out += std::to_string(r);
  }
  return out;
}

Error fail(std::string_view text, std::string message) {
  return Error(Errc::kInvalidArgument, std::move(message), "--device " + quoted(text));
}

}  // namespace

std::span<const std::uint16_t> family_bit_rates(FamilyId family) noexcept {
  return family_facts(family).addressing.bitrates;  // J§1.2.2, E§3.1, F§7.4 0x3001
}

std::string_view to_string(LssProfile profile) noexcept {
  switch (profile) {
    case LssProfile::family_default: return "default";
    case LssProfile::v1: return "v1";
    case LssProfile::v3: return "v3";
    case LssProfile::none: return "none";
  }
  return "?";
}

namespace {

// What one key=value did: nullopt when the key is not of this group, an
// empty string when it was applied, else the reason it was refused.
using KeyResult = std::optional<std::string>;
const KeyResult kApplied{std::string{}};

KeyResult on_off(std::string_view key, std::string_view value, bool& out) {
  if (value == "on") out = true;
  else if (value == "off") out = false;
  else return std::string(key) + " must be on|off, got " + quoted(value);
  return kApplied;
}

KeyResult identity_key(DeviceArgument& arg, const ModelInfo& model, std::string_view key, std::string_view value) {
  if (key == "serial") {
    const auto v = parse_unsigned(value, UINT32_MAX);
    if (!v) return "serial must be a 32-bit number (decimal or 0x hex), got " + quoted(value);
    arg.spec.serial = static_cast<std::uint32_t>(*v);
    arg.serial_given = true;
  } else if (key == "node") {
    if (value == "unconfigured") {
      arg.spec.node_id = 0xFF;
    } else {
      const auto v = parse_unsigned(value, 0xFF);
      if (!v || *v < 1 || *v > 127) return "node must be 1..127 or 'unconfigured', got " + quoted(value);
      arg.spec.node_id = static_cast<std::uint8_t>(*v);
    }
  } else if (key == "channels") {
    const auto v = parse_unsigned(value, 0xFF);
    if (!families::traits(model.family).channel_count_in_eds) {
      if (!v || *v != 1) return std::string("channels: only the rotary series (J) has a 2-channel variant; allowed: 1");
    } else if (!v || (*v != 1 && *v != 2)) {
      return "channels must be 1 or 2, got " + quoted(value);
    }
    arg.spec.channels = static_cast<std::uint8_t>(*v);
  } else if (key == "bitrate") {
    const auto v = parse_unsigned(value, 0xFFFF);
    bool known = false;
    for (const std::uint16_t r : family_bit_rates(model.family)) known = known || (v && *v == r);
    if (!known)
      return "bitrate (kbit/s) for " + std::string(family_name(model.family)) + " must be one of " +
             rate_list(model.family) + ", got " + quoted(value);
    arg.spec.bitrate_kbit = static_cast<std::uint16_t>(*v);
  } else if (key == "vendor" || key == "product" || key == "revision") {
    const auto v = parse_unsigned(value, UINT32_MAX);
    if (!v) return std::string(key) + " must be a 32-bit number (decimal or 0x hex), got " + quoted(value);
    (key == "vendor" ? arg.spec.vendor : key == "product" ? arg.spec.product : arg.spec.revision) =
        static_cast<std::uint32_t>(*v);
  } else {
    return std::nullopt;
  }
  return kApplied;
}

KeyResult lss_key(DeviceArgument& arg, std::string_view key, std::string_view value) {
  if (key == "lss") {
    if (value == "default") arg.spec.lss = LssProfile::family_default;
    else if (value == "v1") arg.spec.lss = LssProfile::v1;
    else if (value == "v3") arg.spec.lss = LssProfile::v3;
    else if (value == "none") arg.spec.lss = LssProfile::none;
    else return "lss must be default|v1|v3|none, got " + quoted(value);
  } else if (key == "fastscan") {
    return on_off(key, value, arg.spec.lss_fastscan);
  } else if (key == "assign") {
    using A = canopen::LssSlaveFeatures::NodeIdAssignment;
    if (value == "accept") arg.spec.assign = A::accept;
    else if (value == "refuse") arg.spec.assign = A::refuse;
    else if (value == "ignore") arg.spec.assign = A::ignore;
    else return "assign must be accept|refuse|ignore, got " + quoted(value);
  } else if (key == "lose_configure" || key == "late_lss") {
    const auto v = parse_unsigned(value, 255);
    if (!v) return std::string(key) + " must be 0..255, got " + quoted(value);
    (key == "late_lss" ? arg.spec.late_lss : arg.spec.lose_configure) = static_cast<std::uint8_t>(*v);
  } else if (key == "late_lss_ms") {
    const auto v = parse_unsigned(value, 60000);
    if (!v) return "late_lss_ms must be 0..60000, got " + quoted(value);
    arg.spec.late_lss_ms = static_cast<std::uint16_t>(*v);
  } else {
    return std::nullopt;
  }
  return kApplied;
}

KeyResult option_key(DeviceArgument& arg, const ModelInfo& model, std::string_view key, std::string_view value) {
  if (key == "segmented") return on_off(key, value, arg.spec.segmented_sdo);
  if (key == "c6") {
    if (!families::traits(model.family).tpdo2_needs_variant)
      return std::string("c6 applies to ifm models only (F§7.3 TPDO2)");
    return on_off(key, value, arg.spec.ifm_c6);
  }
  if (key == "motion") {
    // Checked here so that a typo is an argument error (exit 2), not a
    // device that fails to power on after the buses opened.
    const MotionParseResult m = Motion::parse(value);
    if (!m.ok()) return "motion: " + m.error.message;
    arg.spec.motion = std::string(value);
    return kApplied;
  }
  return std::nullopt;
}

KeyResult apply_key(DeviceArgument& arg, const ModelInfo& model, std::string_view key, std::string_view value) {
  if (KeyResult r = identity_key(arg, model, key, value)) return r;
  if (KeyResult r = lss_key(arg, key, value)) return r;
  if (KeyResult r = option_key(arg, model, key, value)) return r;
  return "unknown key " + quoted(key) +
         " (allowed: serial, node, channels, bitrate, lss, segmented, c6, fastscan, vendor, product, "
         "revision, assign, lose_configure, late_lss, late_lss_ms, motion)";
}

}  // namespace

Result<DeviceArgument> parse_device_argument(std::string_view text, ModelLookup lookup) {
  const std::size_t colon = text.find(':');
  const std::string_view model_name = text.substr(0, colon);
  if (model_name.empty()) return fail(text, "missing the model name (MODEL[:key=value,...])");
  const ModelInfo* model = lookup(model_name);
  if (model == nullptr) return fail(text, "unknown model " + quoted(model_name) + " (see --help for the models)");

  DeviceArgument arg;
  arg.spec.model = model;
  std::string_view rest = colon == std::string_view::npos ? std::string_view{} : text.substr(colon + 1);
  if (colon != std::string_view::npos && rest.empty()) return fail(text, "nothing after ':' (expected key=value)");

  while (!rest.empty()) {
    const std::size_t eq = rest.find('=');
    const std::size_t comma = rest.find(',');
    if (eq == std::string_view::npos || (comma != std::string_view::npos && comma < eq))
      return fail(text, "expected key=value, got " + quoted(rest.substr(0, comma)));
    const std::string_view key = rest.substr(0, eq);
    std::string_view value;
    if (key == "motion") {
      // The motion grammar uses ':' and ',' itself, so it takes the rest.
      value = rest.substr(eq + 1);
      rest = {};
    } else {
      const std::size_t end = rest.find(',', eq);
      value = rest.substr(eq + 1, end == std::string_view::npos ? std::string_view::npos : end - eq - 1);
      rest = end == std::string_view::npos ? std::string_view{} : rest.substr(end + 1);
      if (end != std::string_view::npos && rest.empty()) return fail(text, "trailing ','");
    }
    if (value.empty()) return fail(text, "key " + quoted(key) + " has no value");
    if (KeyResult r = apply_key(arg, *model, key, value); r && !r->empty()) return fail(text, std::move(*r));
  }
  if ((arg.spec.late_lss == 0) != (arg.spec.late_lss_ms == 0))
    return fail(text, "late_lss and late_lss_ms go together (every Nth LSS answer, T ms late)");
  return arg;
}

}  // namespace cobridge::sim
