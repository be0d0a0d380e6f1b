// ConfigPlan: TPDO mapping and parameters (J§1.7.2, E§8.2, F§7.3), heartbeat
// or node guarding, store (0x1010) and the fingerprint. See config_plan_builder.hpp.
#include "bus/config_plan_builder.hpp"

#include <algorithm>
#include <utility>

namespace cobridge::bus::plan_detail {

void Builder::tpdo(std::uint8_t n, const std::optional<config::TpdoSettings>& settings) {
  if (!settings) return;
  const std::string name = "tpdo" + std::to_string(n);
  if (n > profile_.tpdo_count) {
    error(name, "the " + std::string(profile_.series) + " has " + std::to_string(profile_.tpdo_count) + " TPDOs");
    return;
  }
  const auto comm = static_cast<std::uint16_t>(0x1800 + n - 1);
  const auto map = static_cast<std::uint16_t>(0x1A00 + n - 1);
  constexpr auto kComm = bit(StoreGroup::communication);

  if (settings->mapping) mapping(n, name, comm, map, *settings->mapping);

  if (settings->transmission) {
    const std::uint8_t t = *settings->transmission;
    if (!profile_.transmission_type_allowed(n, t)) {
      std::string why = "transmission type " + std::to_string(t) + " is not available on TPDO" + std::to_string(n) +
                        " of the " + std::string(profile_.series);
      if (n == 2 && profile_.tpdo2_sync_only) why += ", which is synchronous only (0 or 1..240; J§1.3.1 / E§4.1 0x1801/2)";
      else why += " (" + std::string(profile_.manual) + " transmission-type table)";
      error(name + " transmission", why);
    } else {
      add_value(name + " transmission", {comm, 2}, t, kComm);
    }
  }
  if (settings->inhibit_100us) add_value(name + " inhibit time", {comm, 3}, *settings->inhibit_100us, kComm);
  if (settings->event_timer_ms) {
    const std::string label = name + " event timer";
    if (eds_.find(comm, 5) == nullptr && n == 2 && profile_.tpdo2_sync_only) {
      error(label, "TPDO2 of the " + std::string(profile_.series) +
                       " has no event timer; it is synchronous only (J§1.3.1 / E§4.1 0x1801)");
    } else {
      add_value(label, {comm, 5}, *settings->event_timer_ms, kComm);
      // F§7.5 0x6200 "event timer of the corresponding PDOs" (range 1..65535:
      // a disabled timer lives in 0x1800/5 only).
      if (n == 1 && profile_.event_timer_alias && *settings->event_timer_ms != 0)
        add_value(label + " (0x6200)", *profile_.event_timer_alias, *settings->event_timer_ms, kComm);
    }
  }
}

void Builder::mapping(std::uint8_t n, const std::string& name, std::uint16_t comm, std::uint16_t map, const std::vector<config::MappingEntry>& entries) {
  const std::string label = name + " mapping";
  bool ok = mapping_objects_fit(n, label, comm, map, entries.size());
  std::vector<std::uint32_t> raw;
  unsigned total_bits = 0;
  bool speed_mapped = false;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const config::MappingEntry& e = entries[i];
    const std::string what = label + " entry " + std::to_string(i + 1) + " (" +
                             (e.signal == config::Signal::raw ? hex(e.raw, 8) : signal_name(e.signal)) + ")";
    const std::optional<std::uint32_t> entry = mapping_entry(what, e, speed_mapped);
    if (!entry) {
      ok = false;
      continue;
    }
    total_bits += *entry & 0xFFu;
    raw.push_back(*entry);
  }
  if (total_bits > profile_.max_pdo_bytes * 8u) {
    error(label, std::to_string(total_bits) + " bits mapped, a PDO carries at most " +
                     std::to_string(profile_.max_pdo_bytes) + " bytes (J§1.7.2, E§8.2, CiA 301)");
    ok = false;
  }
  if (!ok) return;
  // F§7.4 0x3010/1: the ifm speed value is computed only when enabled.
  if (speed_mapped && profile_.speed_enable)
    add_value(name + " speed enable", *profile_.speed_enable, 1, bit(StoreGroup::application));
  PlanStep s;
  s.kind = StepKind::tpdo_mapping;
  s.label = label;
  s.tpdo = n;
  s.comm_index = comm;
  s.map_index = map;
  s.mapping = std::move(raw);
  plan_.steps.push_back(std::move(s));
}

bool Builder::mapping_objects_fit(std::uint8_t n, const std::string& label, std::uint16_t comm, std::uint16_t map,
                                  std::size_t count) {
  bool ok = require(label, {comm, 1}) != nullptr;
  // The manuals' procedure writes sub 0 although F§7.3 prints 0x1A0x/0 as ro
  // (F§4 says the mapping is dynamic), so only its existence is required.
  ok = require(label, {map, 0}, false) != nullptr && ok;
  std::size_t slots = 0;
  while (slots < 64 && eds_.find(map, static_cast<std::uint8_t>(slots + 1)) != nullptr) ++slots;
  const std::size_t max_entries = std::min<std::size_t>(profile_.max_pdo_entries, slots);
  if (count > max_entries) {
    error(label, std::to_string(count) + " entries, but TPDO" + std::to_string(n) + " of the " +
                     std::string(profile_.series) + " maps at most " + std::to_string(max_entries) +
                     (profile_.max_pdo_entries == 5 ? " (J§1.7.2, E§8.2)" : " (device description)"));
    ok = false;
  }
  return ok;
}

std::optional<std::uint32_t> Builder::mapping_entry(const std::string& what, const config::MappingEntry& e,
                                                    bool& speed_mapped) {
  std::uint32_t entry = e.raw;
  if (e.signal != config::Signal::raw) {
    const device::SignalMapping m = profile_.mapping_entry(e.signal);
    if (!m.ok()) {
      error(what, std::string(m.error));
      return std::nullopt;
    }
    entry = m.entry;
  }
  const auto bits = static_cast<std::uint8_t>(entry & 0xFFu);
  ObjectRef object{static_cast<std::uint16_t>(entry >> 16), static_cast<std::uint8_t>((entry >> 8) & 0xFFu)};
  // E§4.1: the multiturn default mapping names 0x6020/1; the object is 0x6004.
  ObjectRef described = object;
  if (profile_.position_alias && object == *profile_.position_alias) described = profile_.position();
  const device::ObjectDesc* d = eds_.find(described.index, described.sub);
  if (d == nullptr) {
    error(what, "object " + object_text(object) + " is not in the device description (" + eds_.source + ")");
    return std::nullopt;
  }
  if (!d->pdo_mapping) {
    error(what, "object " + object_text(object) + " cannot be mapped to a PDO (device description)");
    return std::nullopt;
  }
  if (bits != d->bits()) {
    error(what, "the entry maps " + std::to_string(bits) + " bits, object " + object_text(object) + " has " +
                    std::to_string(d->bits()));
    return std::nullopt;
  }
  if (described.index == 0x6030) speed_mapped = true;
  return entry;
}

void Builder::supervision() {
  constexpr auto kComm = bit(StoreGroup::communication);
  if (dev_.heartbeat_ms) {
    const std::string label = "heartbeat_ms";
    const device::ObjectDesc* d = require(label, {0x1017, 0});
    if (d == nullptr) return;
    PlanStep s;
    s.kind = StepKind::write;
    s.label = label;
    s.write = skeleton(*d, kComm);
    s.write.value = *dev_.heartbeat_ms;
    plan_.heartbeat = *dev_.heartbeat_ms != 0;
    plan_.heartbeat_ms = *dev_.heartbeat_ms;
    if (profile_.heartbeat == device::HeartbeatSupport::uncertain && *dev_.heartbeat_ms != 0) {
      // J§1.2.2 "heartbeat: no": guard at the heartbeat period, life time
      // three periods (a common CiA 301 choice).
      const device::ObjectDesc* gt = require(label, {0x100C, 0});
      const device::ObjectDesc* lf = require(label, {0x100D, 0});
      if (gt == nullptr || lf == nullptr) return;
      SdoWrite g = skeleton(*gt, kComm);
      g.value = *dev_.heartbeat_ms;
      SdoWrite f = skeleton(*lf, kComm);
      f.value = 3;
      s.fallback = {g, f};
      s.fallback_label = "node guarding (heartbeat refused)";
    }
    plan_.steps.push_back(std::move(s));
  }
  if (dev_.guarding) {
    add_value("guarding guard_time_ms", {0x100C, 0}, dev_.guarding->guard_time_ms, kComm);
    add_value("guarding life_time_factor", {0x100D, 0}, dev_.guarding->life_time_factor, kComm);
  }
}

void Builder::store() {
  if (dev_.store == config::StorePolicy::never) return;
  std::uint8_t used = 0;
  for (const PlanStep& s : plan_.steps) {
    if (s.kind == StepKind::write) used |= s.write.groups;
    if (s.kind == StepKind::tpdo_mapping) used |= bit(StoreGroup::communication);
  }
  if (used == 0) return;
  std::vector<StoreTarget> targets;
  auto add = [&targets](std::uint8_t sub, std::uint8_t group) {
    for (StoreTarget& t : targets) {
      if (t.sub == sub) {
        t.groups |= group;
        return;
      }
    }
    targets.push_back(StoreTarget{sub, group});
  };
  if ((used & bit(StoreGroup::communication)) != 0) add(profile_.store.communication, bit(StoreGroup::communication));
  if ((used & bit(StoreGroup::application)) != 0) add(profile_.store.application, bit(StoreGroup::application));
  for (const StoreTarget& t : targets) {
    if (require("store", {0x1010, t.sub}) == nullptr) return;
  }
  PlanStep s;
  s.kind = StepKind::store;
  s.label = "store";
  s.store = std::move(targets);
  plan_.steps.push_back(std::move(s));
}

void Builder::fingerprint() {
  std::vector<std::string> lines;
  lines.push_back("family " + std::string(profile_.name) + " channels " + std::to_string(profile_.channels));
  lines.push_back("store " + std::to_string(static_cast<int>(plan_.store_policy)));
  for (const PlanStep& s : plan_.steps) {
    if (s.kind == StepKind::write) {
      const SdoWrite& w = s.write;
      lines.push_back("w " + hex(w.index, 4) + " " + hex(w.sub, 2) + " " + std::to_string(w.size) + " " +
                      hex(w.value & w.owned(), 8) + " " + hex(w.owned(), 8));
    } else if (s.kind == StepKind::tpdo_mapping) {
      std::string line = "m " + std::to_string(s.tpdo);
      for (std::uint32_t e : s.mapping) line += " " + hex(e, 8);
      lines.push_back(std::move(line));
    }
  }
  std::sort(lines.begin(), lines.end());
  std::uint64_t h = fnv1a64(nullptr, 0);
  for (const std::string& l : lines) {
    h = fnv1a64(l.data(), l.size(), h);
    h = fnv1a64("\n", 1, h);
  }
  plan_.fingerprint_value = h;
  plan_.fingerprint = fingerprint_text(h);
}

}  // namespace cobridge::bus::plan_detail
