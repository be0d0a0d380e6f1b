#include "gateway/config_plan.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <limits>
#include <utility>

namespace cobridge::gateway {

namespace {

using device::DataType;
using device::ObjectRef;

std::string hex(std::uint32_t v, int digits) {
  std::array<char, 16> buf{};
  std::snprintf(buf.data(), buf.size(), "0x%0*X", digits, v);
  return buf.data();
}

std::string object_text(ObjectRef o) {
  std::string s = hex(o.index, 4);
  if (o.sub != 0) s += "/" + std::to_string(o.sub);
  return s;
}

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

// The bounds of an integer type of `bits` bits.
struct Range {
  std::int64_t low;
  std::int64_t high;
};

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

class Builder {
 public:
  Builder(const config::Device& dev, const device::DeviceDescription& eds, const device::FamilyProfile& profile,
          std::uint8_t node_id)
      : dev_(dev), eds_(eds), profile_(profile) {
    plan_.device = dev.name;
    plan_.node_id = node_id;
    plan_.family = profile.family;
    plan_.store_policy = dev.store;
  }

  // make_node_id_plan
  ConfigPlanResult build_node_id(std::uint8_t new_node_id, std::optional<std::uint16_t> bitrate_kbit) {
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
    ConfigPlanResult result;
    if (!errors_.empty()) {
      result.errors = std::move(errors_);
      return result;
    }
    fingerprint();
    result.plan = std::move(plan_);
    return result;
  }

  // make_command_plan
  ConfigPlanResult build_command(CommandKind kind, std::int64_t value) {
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

  ConfigPlanResult build() {
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

    ConfigPlanResult result;
    if (!errors_.empty()) {
      result.errors = std::move(errors_);
      return result;
    }
    fingerprint();
    result.plan = std::move(plan_);
    return result;
  }

 private:
  void error(std::string setting, std::string reason) {
    errors_.push_back(PlanError{dev_.name, std::move(setting), std::move(reason)});
  }

  void add_nmt(std::string label, canopen::NmtCommand cmd) {
    PlanStep s;
    s.kind = StepKind::nmt;
    s.label = std::move(label);
    s.nmt = cmd;
    plan_.steps.push_back(std::move(s));
  }

  // The EDS entry of `o`, or an error naming the setting.
  const device::ObjectDesc* require(const std::string& setting, ObjectRef o, bool writable = true) {
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

  static SdoWrite skeleton(const device::ObjectDesc& d, std::uint8_t groups) {
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
  std::optional<std::uint32_t> encode(const std::string& setting, const device::ObjectDesc& d, std::int64_t value) {
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
  void add_value(std::string label, ObjectRef o, std::int64_t value, std::uint8_t groups) {
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
  void add_bits(std::string label, ObjectRef o, std::uint32_t value, std::uint32_t mask, std::uint8_t groups) {
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

  void tpdo(std::uint8_t n, const std::optional<config::TpdoSettings>& settings) {
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

  void mapping(std::uint8_t n, const std::string& name, std::uint16_t comm, std::uint16_t map,
               const std::vector<config::MappingEntry>& entries) {
    const std::string label = name + " mapping";
    bool ok = require(label, {comm, 1}) != nullptr;
    // The manuals' procedure writes sub 0 although F§7.3 prints 0x1A0x/0 as ro
    // (F§4 says the mapping is dynamic), so only its existence is required.
    ok = require(label, {map, 0}, false) != nullptr && ok;
    std::size_t slots = 0;
    while (slots < 64 && eds_.find(map, static_cast<std::uint8_t>(slots + 1)) != nullptr) ++slots;
    const std::size_t max_entries = std::min<std::size_t>(profile_.max_pdo_entries, slots);
    if (entries.size() > max_entries) {
      error(label, std::to_string(entries.size()) + " entries, but TPDO" + std::to_string(n) + " of the " +
                       std::string(profile_.series) + " maps at most " + std::to_string(max_entries) +
                       (profile_.max_pdo_entries == 5 ? " (J§1.7.2, E§8.2)" : " (device description)"));
      ok = false;
    }
    std::vector<std::uint32_t> raw;
    unsigned total_bits = 0;
    bool speed_mapped = false;
    for (std::size_t i = 0; i < entries.size(); ++i) {
      const config::MappingEntry& e = entries[i];
      const std::string what = label + " entry " + std::to_string(i + 1) + " (" +
                               (e.signal == config::Signal::raw ? hex(e.raw, 8) : signal_name(e.signal)) + ")";
      std::uint32_t entry = e.raw;
      if (e.signal != config::Signal::raw) {
        const device::SignalMapping m = profile_.mapping_entry(e.signal);
        if (!m.ok()) {
          error(what, std::string(m.error));
          ok = false;
          continue;
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
        ok = false;
        continue;
      }
      if (!d->pdo_mapping) {
        error(what, "object " + object_text(object) + " cannot be mapped to a PDO (device description)");
        ok = false;
        continue;
      }
      if (bits != d->bits()) {
        error(what, "the entry maps " + std::to_string(bits) + " bits, object " + object_text(object) + " has " +
                        std::to_string(d->bits()));
        ok = false;
        continue;
      }
      if (described.index == 0x6030) speed_mapped = true;
      total_bits += bits;
      raw.push_back(entry);
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

  void supervision() {
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

  [[nodiscard]] bool scaling_requested() const {
    return dev_.scaling && (dev_.scaling->units_per_rev || dev_.scaling->total_range);
  }

  void operating_parameters() {
    std::uint32_t value = 0;
    std::uint32_t mask = 0;
    std::string label;
    auto name = [&label](const char* n) {
      if (!label.empty()) label += ", ";
      label += n;
    };
    if (dev_.direction) {  // J§1.4.1, E§5.3, F§7.5 bit 0
      mask |= 0x1u;
      value |= static_cast<std::uint32_t>(*dev_.direction);
      name("direction");
    }
    if (scaling_requested()) {  // bit 2, polarity per family
      mask |= 0x4u;
      value |= profile_.scaling_bit(true);
      name("scaling");
    }
    if (dev_.position_filter && profile_.position_filter_in_operating_parameter) {  // J§1.4.1 bits 14..12
      if (*dev_.position_filter > 7) {
        error("position_filter", std::to_string(*dev_.position_filter) + " is outside 0..7 (J§1.4.1 bits 14..12)");
      } else {
        mask |= 0x7000u;
        value |= std::uint32_t{*dev_.position_filter} << 12;
        name("position_filter");
      }
    }
    if (mask == 0) return;
    add_bits(label, device::FamilyProfile::operating_parameters(), value, mask, bit(StoreGroup::application));
  }

  void scaling() {
    if (!dev_.scaling) return;
    constexpr auto kApp = bit(StoreGroup::application);
    // 0x6001 before 0x6002: the device derives one from the other (J§1.4.2, E§5.4/5.5).
    if (dev_.scaling->units_per_rev)
      add_value("scaling units_per_rev", device::FamilyProfile::units_per_revolution(), *dev_.scaling->units_per_rev,
                kApp);
    if (dev_.scaling->total_range)
      add_value("scaling total_range", device::FamilyProfile::total_range(), *dev_.scaling->total_range, kApp);
  }

  [[nodiscard]] std::string channel_suffix(std::uint8_t ch) const {
    return profile_.channels > 1 ? " (channel " + std::to_string(ch) + ")" : std::string{};
  }

  void preset() {
    if (!dev_.preset) return;
    // One preset for the shaft: every channel of a 2-channel rotary gets it.
    for (std::uint8_t ch = 1; ch <= profile_.channels; ++ch)
      add_value("preset" + channel_suffix(ch), profile_.preset(ch), *dev_.preset, bit(StoreGroup::application));
  }

  void cams() {
    if (dev_.cams.empty()) return;
    constexpr auto kApp = bit(StoreGroup::application);
    std::array<std::uint32_t, 3> enable_value{}, enable_mask{}, polarity_value{}, polarity_mask{};
    for (const config::Cam& cam : dev_.cams) {
      const std::string name = "cam " + std::to_string(cam.index);
      const auto slot = profile_.cam_slot(cam.index);
      if (!slot) {
        error(name, std::string(profile_.cam_limit_text()));
        continue;
      }
      // Limits first, switches after: a CAM is not enabled on stale limits.
      if (cam.low) add_value(name + " low", device::FamilyProfile::cam_low(*slot), *cam.low, kApp);
      if (cam.high) add_value(name + " high", device::FamilyProfile::cam_high(*slot), *cam.high, kApp);
      if (cam.hysteresis)
        add_value(name + " hysteresis", device::FamilyProfile::cam_hysteresis(*slot), *cam.hysteresis, kApp);
      const std::uint32_t b = 1u << (slot->number - 1);
      if (cam.enabled) {
        enable_mask[slot->channel] |= b;
        if (*cam.enabled) enable_value[slot->channel] |= b;
      }
      if (cam.polarity) {
        polarity_mask[slot->channel] |= b;
        if (*cam.polarity == config::CamPolarity::inverted) polarity_value[slot->channel] |= b;
      }
    }
    for (std::uint8_t ch = 1; ch <= profile_.channels; ++ch) {
      if (enable_mask[ch] != 0)
        add_bits("cam enable" + channel_suffix(ch), device::FamilyProfile::cam_enable(ch), enable_value[ch],
                 enable_mask[ch], kApp);
      if (polarity_mask[ch] != 0)
        add_bits("cam polarity" + channel_suffix(ch), device::FamilyProfile::cam_polarity(ch), polarity_value[ch],
                 polarity_mask[ch], kApp);
    }
  }

  void work_area() {
    if (!dev_.work_area) return;
    constexpr auto kApp = bit(StoreGroup::application);
    for (std::uint8_t ch = 1; ch <= profile_.channels; ++ch) {
      if (dev_.work_area->low)
        add_value("work_area low" + channel_suffix(ch), device::FamilyProfile::work_area_low(ch), *dev_.work_area->low,
                  kApp);
      if (dev_.work_area->high)
        add_value("work_area high" + channel_suffix(ch), device::FamilyProfile::work_area_high(ch),
                  *dev_.work_area->high, kApp);
    }
  }

  void filters() {
    // Filters are stored with the communication group on the multiturn series (E§11 "Filter": /1, /2).
    constexpr auto kComm = bit(StoreGroup::communication);
    if (dev_.position_filter && !profile_.position_filter_in_operating_parameter) {
      if (profile_.position_filter)
        add_value("position_filter", *profile_.position_filter, *dev_.position_filter, kComm);
      else
        error("position_filter", "the " + std::string(profile_.series) + " has no position filter (" +
                                     std::string(profile_.manual) + "§7.5 has no filter object)");
    }
    if (dev_.speed_filter) {
      if (profile_.speed_filter)
        add_value("speed_filter", *profile_.speed_filter, *dev_.speed_filter, kComm);
      else
        error("speed_filter", "only the multiturn series has a speed filter (E§5.2 0x2010/2)");
    }
  }

  void store() {
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

  void fingerprint() {
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

  const config::Device& dev_;
  const device::DeviceDescription& eds_;
  const device::FamilyProfile& profile_;
  ConfigPlan plan_;
  std::vector<PlanError> errors_;
};

}  // namespace

std::string PlanError::to_string() const { return "device '" + device + "': " + setting + ": " + reason; }

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
  return Builder(device, description, profile, current_node_id).build_node_id(new_node_id, bitrate_kbit);
}

ConfigPlanResult make_command_plan(const std::string& device_name, const device::DeviceDescription& description,
                                   const device::FamilyProfile& profile, std::uint8_t node_id, CommandKind kind,
                                   std::int64_t value) {
  config::Device device;
  device.name = device_name;
  return Builder(device, description, profile, node_id).build_command(kind, value);
}

ConfigPlanResult make_config_plan(const config::Device& device, const device::DeviceDescription& description,
                                  const device::FamilyProfile& profile, std::uint8_t node_id) {
  return Builder(device, description, profile, node_id).build();
}

}  // namespace cobridge::gateway
