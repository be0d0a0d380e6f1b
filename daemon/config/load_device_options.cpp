// The per-device tables of [[device]]: TPDO mapping, guarding, scaling,
// work area and CAMs.
#include "config/loader.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <map>
#include <system_error>

namespace cobridge::config::detail {

// ---- [[device]] --------------------------------------------------------

std::optional<MappingEntry> Loader::read_mapping_entry(TableReader& r, const toml::node& item) {
  static constexpr std::array<std::pair<std::string_view, Signal>, 8> kSignals{{{"position", Signal::position},
                                                                                {"speed", Signal::speed},
                                                                                {"cam", Signal::cam},
                                                                                {"work_area", Signal::work_area},
                                                                                {"alarms", Signal::alarms},
                                                                                {"warnings", Signal::warnings},
                                                                                {"temperature", Signal::temperature},
                                                                                {"voltage", Signal::voltage}}};
  const auto* s = item.as_string();
  if (s == nullptr) {
    r.wrong_type(item, r.path("mapping") + " entry", "a string");
    return std::nullopt;
  }
  const std::string& text = s->get();
  for (const auto& [name, signal] : kSignals) {
    if (name == text) return MappingEntry{signal, 0};
  }
  const bool hex = text.size() == 10 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X') &&
                   std::all_of(text.begin() + 2, text.end(), [](char c) {
                     return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F');
                   });
  if (hex) {
    const auto raw = static_cast<std::uint32_t>(std::stoul(text.substr(2), nullptr, 16));
    const std::uint32_t bits = raw & 0xFFU;
    if (bits == 0 || bits > 64 || (raw >> 16) == 0) {
      r.error(item, r.path("mapping") + " entry " + in_quotes(text) +
                        " is not a valid mapping entry (index must be non-zero, bit length 1..64)");
      return std::nullopt;
    }
    return MappingEntry{Signal::raw, raw};
  }
  r.error(item, r.path("mapping") + " entry " + in_quotes(text) +
                    " is not allowed (allowed: position, speed, cam, work_area, alarms, warnings, temperature, "
                    "voltage, or a raw entry \"0xIIIISSLL\" = index, sub-index, bit length)");
  return std::nullopt;
}

std::optional<TpdoSettings> Loader::read_tpdo(TableReader& device, std::string_view key) {
  const toml::table* t = device.subtable(key);
  if (t == nullptr) return std::nullopt;
  const std::string k(key);
  TableReader r(*t, "[device." + k + "]", device.context(), k + ".", sink_);
  r.check_keys({"mapping", "transmission", "event_timer_ms", "inhibit_100us"});
  TpdoSettings tpdo;
  if (const toml::array* m = r.array("mapping")) {
    std::vector<MappingEntry> entries;
    bool ok = true;
    std::uint32_t raw_bits = 0;
    for (const toml::node& item : *m) {
      if (auto e = read_mapping_entry(r, item)) {
        entries.push_back(*e);
        if (e->signal == Signal::raw) raw_bits += e->raw & 0xFFU;
      } else {
        ok = false;
      }
    }
    // CiA 301: a PDO carries at most 8 bytes.
    if (entries.size() > 8 || raw_bits > 64) {
      r.error(*r.find("mapping"), r.path("mapping") + " does not fit in a PDO (at most 8 entries and 64 bits)");
      ok = false;
    }
    if (ok) tpdo.mapping = std::move(entries);
  }
  if (const toml::node* n = r.find("transmission")) {
    if (const auto* s = n->as_string()) {
      const std::string& v = s->get();
      if (v == "event") {
        tpdo.transmission = 254;
      } else if (v == "sync") {
        tpdo.transmission = 1;
      } else if (v == "cyclic-measuring") {
        tpdo.transmission = 255;
      } else {
        r.error(*n, r.path("transmission") + " " + in_quotes(v) +
                        " is not allowed (allowed: \"event\", \"sync\", \"cyclic-measuring\", or 0..240, 254, 255)");
      }
    } else if (const auto* i = n->as_integer()) {
      const std::int64_t v = i->get();
      if ((v >= 0 && v <= 240) || v == 254 || v == 255) {
        tpdo.transmission = static_cast<std::uint8_t>(v);
      } else {
        r.error(*n, r.path("transmission") + " " + std::to_string(v) +
                        " is not allowed (allowed: 0..240, 254, 255, \"event\", \"sync\", \"cyclic-measuring\")");
      }
    } else {
      r.wrong_type(*n, r.path("transmission"), "an integer or a string");
    }
  }
  if (auto v = r.integer("event_timer_ms", 0, kU16)) tpdo.event_timer_ms = static_cast<std::uint16_t>(*v);
  if (auto v = r.integer("inhibit_100us", 0, kU16)) tpdo.inhibit_100us = static_cast<std::uint16_t>(*v);
  return tpdo;
}

std::optional<Guarding> Loader::read_guarding(TableReader& device) {
  const toml::table* t = device.subtable("guarding");
  if (t == nullptr) return std::nullopt;
  TableReader r(*t, "[device.guarding]", device.context(), "guarding.", sink_);
  r.check_keys({"guard_time_ms", "life_time_factor"});
  auto time = r.integer("guard_time_ms", 1, kU16);
  auto factor = r.integer("life_time_factor", 1, kU8);
  if (r.find("guard_time_ms") == nullptr) r.missing("guard_time_ms");
  if (r.find("life_time_factor") == nullptr) r.missing("life_time_factor");
  if (!time || !factor) return std::nullopt;
  return Guarding{static_cast<std::uint16_t>(*time), static_cast<std::uint8_t>(*factor)};
}

std::optional<Scaling> Loader::read_scaling(TableReader& device) {
  const toml::table* t = device.subtable("scaling");
  if (t == nullptr) return std::nullopt;
  TableReader r(*t, "[device.scaling]", device.context(), "scaling.", sink_);
  r.check_keys({"units_per_rev", "total_range"});
  Scaling s;
  if (auto v = r.integer("units_per_rev", 1, kU32)) s.units_per_rev = static_cast<std::uint32_t>(*v);
  if (auto v = r.integer("total_range", 1, kU32)) s.total_range = static_cast<std::uint32_t>(*v);
  return s;
}

std::optional<WorkArea> Loader::read_work_area(TableReader& device) {
  const toml::table* t = device.subtable("work_area");
  if (t == nullptr) return std::nullopt;
  TableReader r(*t, "[device.work_area]", device.context(), "work_area.", sink_);
  r.check_keys({"low", "high"});
  WorkArea w;
  if (auto v = r.integer("low", kI32Min, kI32Max)) w.low = static_cast<std::int32_t>(*v);
  if (auto v = r.integer("high", kI32Min, kI32Max)) w.high = static_cast<std::int32_t>(*v);
  return w;
}

void Loader::read_cams(TableReader& device, Device& d, std::int64_t max_index) {
  const toml::node* n = device.find("cam");
  if (n == nullptr) return;
  const auto* arr = n->as_array();
  if (arr == nullptr || !arr->is_array_of_tables()) {
    device.wrong_type(*n, "cam", "an array of tables ([[device.cam]])");
    return;
  }
  std::array<const toml::node*, 9> seen{};
  for (const toml::node& e : *arr) {
    const auto& t = *e.as_table();
    TableReader r(t, "[[device.cam]]", device.context(), "cam.", sink_);
    r.check_keys({"index", "low", "high", "hysteresis", "enabled", "polarity"});
    Cam cam;
    const auto index = r.integer("index", 1, max_index);
    if (r.find("index") == nullptr) r.missing("index");
    if (index) {
      const auto i = static_cast<std::size_t>(*index);
      if (seen[i] != nullptr) {
        r.error(*r.find("index"), "cam index " + std::to_string(i) + " is defined twice (first at " +
                                      at(location(sink_, *seen[i])) + ")");
      } else {
        seen[i] = r.find("index");
      }
      cam.index = static_cast<std::uint8_t>(*index);
    }
    // The widest of the families' limit types: INTEGER32 (J) and
    // UNSIGNED32 (F§7.5 0x631x); the gateway narrows it per object.
    if (auto v = r.integer("low", kI32Min, kU32)) cam.low = *v;
    if (auto v = r.integer("high", kI32Min, kU32)) cam.high = *v;
    // INTEGER16 on the rotary series (J 0x633x), UNSIGNED16 (E), u32 (F):
    // 0..32767 is valid everywhere.
    if (auto v = r.integer("hysteresis", 0, 32767)) cam.hysteresis = static_cast<std::uint16_t>(*v);
    cam.enabled = r.boolean("enabled");
    cam.polarity = r.choice<CamPolarity>("polarity", {{"normal", CamPolarity::normal}, {"inverted", CamPolarity::inverted}});
    if (index) d.cams.push_back(cam);
  }
  std::sort(d.cams.begin(), d.cams.end(), [](const Cam& a, const Cam& b) { return a.index < b.index; });
}

}  // namespace cobridge::config::detail
