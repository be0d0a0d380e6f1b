// [[bus]]: one SocketCAN interface each, its bit rate and node-ID pool.
#include "config/loader.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <map>
#include <system_error>

namespace cobridge::config::detail {

// ---- [[bus]] -----------------------------------------------------------

// Accepts "10-60", "10", 10, or an array of those.
void Loader::read_node_pool(TableReader& r, Bus& bus) {
  const toml::node* n = r.find("node_pool");
  if (n == nullptr) {
    for (int id = 1; id <= 127; ++id) bus.node_pool.push_back(static_cast<std::uint8_t>(id));
    bus.node_pool_default = true;
    return;
  }
  std::array<bool, 128> in_pool{};
  bool ok = true;
  auto add_item = [&](const toml::node& item) {
    if (const auto* i = item.as_integer()) {
      const std::int64_t v = i->get();
      if (v < 1 || v > 127) {
        r.error(item, "node_pool entry " + std::to_string(v) + " is out of range (allowed: 1..127)");
        ok = false;
        return;
      }
      in_pool[static_cast<std::size_t>(v)] = true;
      return;
    }
    const auto* s = item.as_string();
    if (s == nullptr) {
      r.wrong_type(item, "node_pool entry", "an integer or a string like \"10-60\"");
      ok = false;
      return;
    }
    const std::string& text = s->get();
    const auto range = parse_range(text);
    if (!range) {
      r.error(item, "node_pool " + in_quotes(text) +
                        " is not a valid node-ID range (allowed: \"low-high\" with 1 <= low <= high <= 127, or a node-ID)");
      ok = false;
      return;
    }
    const auto [low, high] = *range;
    for (unsigned id = low; id <= high; ++id) in_pool[id] = true;
  };
  if (const auto* a = n->as_array()) {
    for (const toml::node& item : *a) add_item(item);
  } else {
    add_item(*n);
  }
  if (!ok) return;
  for (std::size_t id = 1; id <= 127; ++id) {
    if (in_pool[id]) bus.node_pool.push_back(static_cast<std::uint8_t>(id));
  }
  if (bus.node_pool.empty() && bus.commissioning == Commissioning::automatic) {
    r.error(*n, "node_pool is empty but commissioning is \"automatic\" (give node-IDs to assign, or set "
                "commissioning to \"manual\" or \"off\")");
  }
}

// `key` must be an array of tables ([[key]]); `read` gets each table. Other
// elements of a mixed array are reported by the type check and skipped.
void Loader::read_bus(const toml::table& t) {
  Bus bus;
  BusSpots spots;
  bus.where = location(sink_, t);
  const auto* name_node = t.get("name");
  TableReader r(t, "[[bus]]", entry_context("bus", config_.buses.size() + 1, name_node), "", sink_);
  r.check_keys({"name", "interface", "bitrate", "sync_period_ms", "sync_counter", "discovery", "discovery_period_s",
                "node_pool", "commissioning", "swap_policy", "lss_timeout_ms", "lss_timeout_min_ms", "sdo_timeout_ms",
                "sdo_retries", "foreign_nmt", "unknown_devices", "recorder_seconds", "capture_after_s",
                "capture_cap_mib", "capture_budget_per_hour"});
  read_name(r, name_node, bus.name, spots.name, spots.has_name);
  read_bus_interface(r, bus, spots);
  read_bus_sync(r, bus);
  if (auto v = r.boolean("discovery")) bus.discovery = *v;
  if (auto v = r.integer("discovery_period_s", 1, 86400)) bus.discovery_period_s = static_cast<std::uint32_t>(*v);
  if (auto v = r.choice<Commissioning>("commissioning", {{"automatic", Commissioning::automatic},
                                                         {"manual", Commissioning::manual},
                                                         {"off", Commissioning::off}})) {
    bus.commissioning = *v;
  }
  read_node_pool(r, bus);
  if (auto v = r.choice<SwapPolicy>("swap_policy", {{"same-model", SwapPolicy::same_model}, {"off", SwapPolicy::off}})) {
    bus.swap_policy = *v;
  }
  read_bus_timeouts(r, bus);
  read_bus_recorder(r, bus);
  if (auto v = r.choice<ForeignNmt>("foreign_nmt", {{"restart", ForeignNmt::restart}, {"respect", ForeignNmt::respect}})) {
    bus.foreign_nmt = *v;
  }
  if (auto v = r.choice<UnknownDevices>("unknown_devices",
                                        {{"ignore", UnknownDevices::ignore}, {"assign", UnknownDevices::assign}})) {
    bus.unknown_devices = *v;
  }
  config_.buses.push_back(std::move(bus));
  bus_spots_.push_back(spots);
}

void Loader::read_bus_interface(TableReader& r, Bus& bus, BusSpots& spots) {
  if (auto v = r.string("interface")) {
    if (is_interface_name(*v)) {
      bus.interface = *v;
      spots.interface = location(sink_, *r.find("interface"));
      spots.has_interface = true;
    } else {
      r.error(*r.find("interface"), "interface " + in_quotes(*v) +
                                        " is not a valid Linux interface name (1 to 15 characters, no '/', ':' "
                                        "or white space)");
    }
  } else if (r.find("interface") == nullptr) {
    r.missing("interface");
  }
}

// The bit rate and the SYNC producer's period and counter.
void Loader::read_bus_sync(TableReader& r, Bus& bus) {
  if (auto v = r.integer_in("bitrate", {10, 20, 50, 100, 125, 250, 500, 800, 1000})) {
    bus.bitrate_kbit = static_cast<std::uint16_t>(*v);
  }
  // 0x1006 holds the period in microseconds as UNSIGNED32 (CiA 301).
  if (auto v = r.integer("sync_period_ms", 0, kU32 / 1000)) bus.sync_period_ms = static_cast<std::uint32_t>(*v);
  if (auto v = r.integer("sync_counter", 0, 240)) {
    if (*v == 1) {
      r.error(*r.find("sync_counter"), "sync_counter 1 is not allowed (allowed: 0 = no counter, or 2..240; CiA 301 0x1019)");
    } else {
      bus.sync_counter = static_cast<std::uint8_t>(*v);
    }
  }
}

// The LSS and SDO timeouts and SDO retries.
void Loader::read_bus_timeouts(TableReader& r, Bus& bus) {
  if (auto v = r.integer("lss_timeout_ms", 1, 60000)) bus.lss_timeout_ms = static_cast<std::uint32_t>(*v);
  if (auto v = r.integer("lss_timeout_min_ms", 1, 60000)) {
    if (static_cast<std::uint32_t>(*v) > bus.lss_timeout_ms) {
      r.error(*r.find("lss_timeout_min_ms"), "lss_timeout_min_ms " + std::to_string(*v) +
                                                 " is above lss_timeout_ms " + std::to_string(bus.lss_timeout_ms));
    } else {
      bus.lss_timeout_min_ms = static_cast<std::uint32_t>(*v);
    }
  }
  if (auto v = r.integer("sdo_timeout_ms", 1, 60000)) bus.sdo_timeout_ms = static_cast<std::uint32_t>(*v);
  if (auto v = r.integer("sdo_retries", 0, 10)) bus.sdo_retries = static_cast<std::uint8_t>(*v);
}

// The flight recorder's window, its captures' disk cap and write budget.
// capture_after_s is at least 0.5 s: each window makes one capture, and at
// 0 s a storm of faults wrote up to 16 captures per 100 ms (flash wear).
void Loader::read_bus_recorder(TableReader& r, Bus& bus) {
  if (auto v = r.integer("recorder_seconds", 0, 600)) bus.recorder_seconds = static_cast<std::uint32_t>(*v);
  if (auto v = r.number("capture_after_s", 0.5, 60)) bus.capture_after_ms = static_cast<std::uint32_t>(*v * 1000 + 0.5);
  if (auto v = r.integer("capture_cap_mib", 1, 1u << 20)) bus.capture_cap_mib = static_cast<std::uint32_t>(*v);
  if (auto v = r.integer("capture_budget_per_hour", 1, 7200))
    bus.capture_budget_per_hour = static_cast<std::uint32_t>(*v);
}

}  // namespace cobridge::config::detail
