// ConfigPlan: the entry points, the node-ID and command plans and the write
// primitives of the Builder (config_plan_builder.hpp says where the rest is).
#include "bus/config_plan.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <limits>
#include <utility>

#include "bus/config_plan_builder.hpp"

namespace cobridge::bus {

namespace plan_detail {

std::string signal_name(config::Signal s) {
  switch (s) {
    case config::Signal::position: return "position";
    case config::Signal::speed: return "speed";
    case config::Signal::cam: return "cam";
    case config::Signal::work_area: return "work_area";
    case config::Signal::alarms: return "alarms";
    case config::Signal::warnings: return "warnings";
    case config::Signal::temperature: return "temperature";
    case config::Signal::voltage: return "voltage";
    case config::Signal::raw: return "raw";
  }
  return "?";
}

std::optional<Range> type_range(DataType t) {
  const std::uint32_t bits = device::bit_size(t);
  if (t == DataType::kBoolean) return Range{0, 1};
  if (bits == 0 || bits > 32) return std::nullopt;
  if (device::is_signed_integer(t)) {
    const std::int64_t half = std::int64_t{1} << (bits - 1);
    return Range{-half, half - 1};
  }
  if (device::is_unsigned_integer(t)) return Range{0, (std::int64_t{1} << bits) - 1};
  return std::nullopt;
}

std::int64_t limit_value(const device::ObjectDesc& d, const device::EdsValue& v) {
  const std::uint32_t bits = device::bit_size(d.data_type);
  if (device::is_signed_integer(d.data_type) && bits > 0 && bits < 64) {
    const std::uint64_t sign = std::uint64_t{1} << (bits - 1);
    const std::uint64_t raw = v.integer & ((sign << 1) - 1);
    return static_cast<std::int64_t>(raw ^ sign) - static_cast<std::int64_t>(sign);
  }
  return static_cast<std::int64_t>(v.integer);
}

// make_node_id_plan
ConfigPlanResult Builder::build_node_id(std::uint8_t new_node_id, std::optional<std::uint16_t> bitrate_kbit) {
  constexpr auto kNode = bit(StoreGroup::node_id);
  add_nmt("enter pre-operational", canopen::NmtCommand::enter_preop);
  if (new_node_id < 1 || new_node_id > 127) {
    error("node_id", std::to_string(new_node_id) + " is outside 1..127 (CiA 301)");
  } else {
    add_value("node_id", profile_.node_id_object, profile_.encode_node_id(new_node_id), kNode);
  }
  if (bitrate_kbit) {
    if (const auto v = profile_.encode_bitrate(*bitrate_kbit)) {
      add_value("bitrate", profile_.bitrate_object, *v, kNode);
    } else {
      error("bitrate", std::to_string(*bitrate_kbit) + " kbit/s is not a bit rate of the " +
                           std::string(profile_.series) + " (" + std::string(profile_.manual) + ")");
    }
  }
  plan_.store_policy = config::StorePolicy::always;
  if (require("store", {0x1010, profile_.store.node_id}) != nullptr) {
    PlanStep s;
    s.kind = StepKind::store;
    s.label = "store node-ID";
    s.store = {StoreTarget{profile_.store.node_id, kNode}};
    plan_.steps.push_back(std::move(s));
  }
  return finish();
}

// make_command_plan
ConfigPlanResult Builder::build_command(CommandKind kind, std::int64_t value) {
  plan_.store_policy = config::StorePolicy::never;
  switch (kind) {
    case CommandKind::preset:
      for (std::uint8_t ch = 1; ch <= profile_.channels; ++ch) {
        const std::size_t before = plan_.steps.size();
        add_value("preset" + channel_suffix(ch), profile_.preset(ch), value, bit(StoreGroup::application));
        // A preset is an action, not a state: write it even if the object
        // already holds the value.
        if (plan_.steps.size() > before) plan_.steps.back().write.read_first = false;
      }
      break;
    case CommandKind::nmt_reset:
      add_nmt("NMT reset", canopen::NmtCommand::reset_node);
      break;
    case CommandKind::store: {
      if (profile_.store_only_pre_operational) add_nmt("enter pre-operational", canopen::NmtCommand::enter_preop);
      plan_.store_policy = config::StorePolicy::always;
      std::vector<StoreTarget> targets{{profile_.store.communication, bit(StoreGroup::communication)}};
      if (profile_.store.application == profile_.store.communication) {
        targets.front().groups |= bit(StoreGroup::application);
      } else {
        targets.push_back({profile_.store.application, bit(StoreGroup::application)});
      }
      bool present = true;
      for (const StoreTarget& t : targets) present = present && require("store", {0x1010, t.sub}) != nullptr;
      if (present) {
        PlanStep s;
        s.kind = StepKind::store;
        s.label = "store";
        s.store = std::move(targets);
        plan_.steps.push_back(std::move(s));
      }
      if (profile_.store_only_pre_operational) add_nmt("start", canopen::NmtCommand::start);
      break;
    }
  }
  ConfigPlanResult result;
  if (!errors_.empty()) {
    result.errors = std::move(errors_);
    return result;
  }
  result.plan = std::move(plan_);
  return result;
}

ConfigPlanResult Builder::build() {
  add_nmt("enter pre-operational", canopen::NmtCommand::enter_preop);
  tpdo(1, dev_.tpdo1);
  tpdo(2, dev_.tpdo2);
  supervision();
  operating_parameters();
  scaling();
  preset();
  cams();
  work_area();
  filters();
  store();
  add_nmt("start", canopen::NmtCommand::start);

  return finish();
}

// The plan, fingerprinted, or every error found while building it.
ConfigPlanResult Builder::finish() {
  ConfigPlanResult result;
  if (!errors_.empty()) {
    result.errors = std::move(errors_);
    return result;
  }
  fingerprint();
  result.plan = std::move(plan_);
  return result;
}

void Builder::error(std::string setting, std::string reason) {
  errors_.push_back(PlanError{dev_.name, std::move(setting), std::move(reason)});
}

void Builder::add_nmt(std::string label, canopen::NmtCommand cmd) {
  PlanStep s;
  s.kind = StepKind::nmt;
  s.label = std::move(label);
  s.nmt = cmd;
  plan_.steps.push_back(std::move(s));
}

// The EDS entry of `o`, or an error naming the setting.
const device::ObjectDesc* Builder::require(const std::string& setting, ObjectRef o, bool writable) {
  const device::ObjectDesc* d = eds_.find(o.index, o.sub);
  if (d == nullptr) {
    error(setting, "object " + object_text(o) + " is not in the device description (" + eds_.source + ")");
    return nullptr;
  }
  if (writable && (d->access == device::AccessType::kRo || d->access == device::AccessType::kConst)) {
    error(setting, "object " + object_text(o) + " is read-only in the device description (" + eds_.source + ")");
    return nullptr;
  }
  const std::uint32_t bits = d->bits();
  if (bits == 0 || bits > 32) {
    error(setting, "object " + object_text(o) + " has type " + std::string(device::to_string(d->data_type)) +
                       ", which the plan cannot write");
    return nullptr;
  }
  return d;
}

SdoWrite Builder::skeleton(const device::ObjectDesc& d, std::uint8_t groups) {
  SdoWrite w;
  w.index = d.index;
  w.sub = d.sub;
  w.size = static_cast<std::uint8_t>((d.bits() + 7) / 8);
  w.groups = groups;
  // A write-only object cannot be compared or read back (CiA 301 abort 0x06010001).
  if (d.access == device::AccessType::kWo) {
    w.read_first = false;
    w.verify = false;
  }
  return w;
}

// `value` checked against the object's type and EDS limits; the bit pattern.
std::optional<std::uint32_t> Builder::encode(const std::string& setting, const device::ObjectDesc& d, std::int64_t value) {
  const auto range = type_range(d.data_type);
  const ObjectRef o{d.index, d.sub};
  if (!range) {
    error(setting, "object " + object_text(o) + " is not an integer");
    return std::nullopt;
  }
  std::int64_t low = range->low;
  std::int64_t high = range->high;
  if (d.low_limit.kind == device::EdsValue::Kind::kInteger) low = std::max(low, limit_value(d, d.low_limit));
  if (d.high_limit.kind == device::EdsValue::Kind::kInteger) high = std::min(high, limit_value(d, d.high_limit));
  if (value < low || value > high) {
    error(setting, std::to_string(value) + " is outside " + std::to_string(low) + ".." + std::to_string(high) +
                       " of object " + object_text(o) + " (" + std::string(device::to_string(d.data_type)) + ")");
    errors_.back().out_of_range = true;
    return std::nullopt;
  }
  return static_cast<std::uint32_t>(static_cast<std::uint64_t>(value) & 0xFFFFFFFFull);
}

// A plain write of `value` to `o`.
void Builder::add_value(std::string label, ObjectRef o, std::int64_t value, std::uint8_t groups) {
  const device::ObjectDesc* d = require(label, o);
  if (d == nullptr) return;
  const auto pattern = encode(label, *d, value);
  if (!pattern) return;
  PlanStep s;
  s.kind = StepKind::write;
  s.label = std::move(label);
  s.write = skeleton(*d, groups);
  s.write.value = *pattern;
  plan_.steps.push_back(std::move(s));
}

// A read-modify-write of the bits in `mask`.
void Builder::add_bits(std::string label, ObjectRef o, std::uint32_t value, std::uint32_t mask, std::uint8_t groups) {
  const device::ObjectDesc* d = require(label, o);
  if (d == nullptr) return;
  PlanStep s;
  s.kind = StepKind::write;
  s.label = std::move(label);
  s.write = skeleton(*d, groups);
  if ((mask & ~s.write.size_mask()) != 0) {
    error(s.label, "object " + object_text(o) + " has " + std::to_string(s.write.size * 8) + " bits, the setting needs " +
                       hex(mask, 8));
    return;
  }
  s.write.value = value & mask;
  s.write.mask = mask;
  plan_.steps.push_back(std::move(s));
}

}  // namespace plan_detail

std::string PlanError::to_string() const { return "device '" + device + "': " + setting + ": " + reason; }

Error PlanError::to_error() const {
  return Error(Errc::kInvalidArgument, reason, "device '" + device + "': " + setting);
}

std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t seed) noexcept {
  std::uint64_t h = seed;
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < size; ++i) {
    h ^= p[i];
    h *= 0x100000001b3ull;
  }
  return h;
}

std::string fingerprint_text(std::uint64_t value) {
  std::array<char, 17> buf{};
  std::snprintf(buf.data(), buf.size(), "%016llx", static_cast<unsigned long long>(value));
  return buf.data();
}

ConfigPlanResult make_node_id_plan(const std::string& device_name, const device::DeviceDescription& description,
                                   const device::FamilyProfile& profile, std::uint8_t current_node_id,
                                   std::uint8_t new_node_id, std::optional<std::uint16_t> bitrate_kbit) {
  config::Device device;
  device.name = device_name;
  return plan_detail::Builder(device, description, profile, current_node_id).build_node_id(new_node_id, bitrate_kbit);
}

ConfigPlanResult make_command_plan(const std::string& device_name, const device::DeviceDescription& description,
                                   const device::FamilyProfile& profile, std::uint8_t node_id, CommandKind kind,
                                   std::int64_t value) {
  config::Device device;
  device.name = device_name;
  return plan_detail::Builder(device, description, profile, node_id).build_command(kind, value);
}

ConfigPlanResult make_config_plan(const config::Device& device, const device::DeviceDescription& description,
                                  const device::FamilyProfile& profile, std::uint8_t node_id) {
  return plan_detail::Builder(device, description, profile, node_id).build();
}

}  // namespace cobridge::bus
