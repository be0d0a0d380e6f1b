#include "bus/config_drift.hpp"

#include <algorithm>
#include <cstdio>

namespace cobridge::bus {
namespace {

// CiA 301 §7.5.2.35: TPDO COB-ID bit 31 set = the PDO does not exist.
constexpr std::uint32_t kPdoInvalid = 0x80000000u;

std::optional<ConfiguredObject> from_write(const SdoWrite& w, const std::string& label) {
  ConfiguredObject o;
  o.index = w.index;
  o.sub = w.sub;
  o.size = w.size;
  o.owned = w.owned();
  o.value = w.value & o.owned;
  o.name = label;
  return o;
}

// The objects of a TPDO mapping step (plan_runner.cpp's remapping writes).
std::optional<ConfiguredObject> from_mapping(const PlanStep& s, std::uint16_t index, std::uint8_t sub) {
  ConfiguredObject o;
  o.index = index;
  o.sub = sub;
  if (index == s.comm_index && sub == 1) {
    o.owned = kPdoInvalid;  // the COB-ID itself is the device's; its valid bit is ours
    o.value = s.mapping.empty() ? kPdoInvalid : 0;
    o.name = s.label + " (PDO valid bit)";
    return o;
  }
  if (index != s.map_index) return std::nullopt;
  if (sub == 0) {
    o.size = 1;
    o.owned = 0xFFu;
    o.value = static_cast<std::uint32_t>(s.mapping.size());
    o.name = s.label + " (number of entries)";
    return o;
  }
  // Entries beyond the configured number are not mapped: theirs is no setting.
  if (sub > s.mapping.size()) return std::nullopt;
  o.value = s.mapping[sub - 1U];
  o.name = s.label + " entry " + std::to_string(sub);
  return o;
}

std::uint32_t little_endian(std::span<const std::uint8_t> bytes) {
  std::uint32_t v = 0;
  const std::size_t n = std::min<std::size_t>(bytes.size(), 4);
  for (std::size_t i = 0; i < n; ++i) v |= static_cast<std::uint32_t>(bytes[i]) << (8U * i);
  return v;
}

std::uint32_t size_mask(std::uint8_t size) { return size >= 4 ? 0xFFFFFFFFu : ((1u << (8u * size)) - 1u); }

}  // namespace

std::optional<ConfiguredObject> configured_object(const ConfigPlan& plan, std::uint16_t index, std::uint8_t sub) {
  // The last step naming the object wins: it is what the plan leaves there.
  std::optional<ConfiguredObject> found;
  for (const auto& s : plan.steps) {
    if (s.kind == StepKind::write && s.write.index == index && s.write.sub == sub && s.write.owned() != 0) {
      found = from_write(s.write, s.label);
    } else if (s.kind == StepKind::tpdo_mapping) {
      if (auto o = from_mapping(s, index, sub)) found = std::move(o);
    }
  }
  return found;
}

DriftCheck check_write(const ConfigPlan& plan, std::uint16_t index, std::uint8_t sub,
                       std::span<const std::uint8_t> bytes, std::string writer, WallTime at) {
  DriftCheck c;
  const auto o = configured_object(plan, index, sub);
  if (!o) return c;
  c.configured = true;
  const std::uint32_t written = little_endian(bytes) & size_mask(o->size);
  c.differs = ((written ^ o->value) & o->owned) != 0;
  DriftRecord& r = c.record;
  r.index = index;
  r.sub = sub;
  r.object = object_key(index, sub);
  r.name = o->name;
  r.configured = o->value;
  r.owned = o->owned & size_mask(o->size);
  r.value = written;
  r.writer = std::move(writer);
  r.at = at;
  return c;
}

std::string object_key(std::uint16_t index, std::uint8_t sub) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%04X:%02X", static_cast<unsigned>(index), static_cast<unsigned>(sub));
  return buf;
}

std::string number_text(std::uint32_t value) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%u (0x%X)", static_cast<unsigned>(value), static_cast<unsigned>(value));
  return buf;
}

std::string drift_text(const DriftRecord& r) {
  std::string text = r.object;
  if (!r.name.empty()) text += " (" + r.name + ")";
  text += " set to " + number_text(r.value) + " by " + r.writer + " (configured " + number_text(r.configured);
  // A read-modify-write object (0x6000): say which bits are configured.
  if (r.owned != 0xFFFFFFFFu && r.owned != 0xFFFFu && r.owned != 0xFFu) {
    char buf[24];
    std::snprintf(buf, sizeof buf, " in bits 0x%X", static_cast<unsigned>(r.owned));
    text += buf;
  }
  return text + ")";
}

DriftChange apply_check(std::vector<DriftRecord>& open, const DriftCheck& check) {
  if (!check.configured) return DriftChange::none;
  const auto it = std::find_if(open.begin(), open.end(), [&](const DriftRecord& r) {
    return r.index == check.record.index && r.sub == check.record.sub;
  });
  if (!check.differs) {
    if (it == open.end()) return DriftChange::none;
    open.erase(it);
    return DriftChange::restored;
  }
  if (it != open.end()) open.erase(it);
  open.push_back(check.record);
  return DriftChange::opened;
}

DriftRecord* open_record(std::vector<DriftRecord>& open, std::uint16_t index, std::uint8_t sub) {
  const auto it = std::find_if(open.begin(), open.end(),
                               [&](const DriftRecord& r) { return r.index == index && r.sub == sub; });
  return it == open.end() ? nullptr : &*it;
}

bool repeats_open_record(const std::vector<DriftRecord>& open, const DriftCheck& check) {
  if (!check.configured) return false;
  return std::any_of(open.begin(), open.end(), [&](const DriftRecord& r) {
    return r.index == check.record.index && r.sub == check.record.sub && r.value == check.record.value &&
           r.writer == check.record.writer;
  });
}

}  // namespace cobridge::bus
