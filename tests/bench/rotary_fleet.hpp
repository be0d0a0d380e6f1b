// The fleet the hot-path benches and the allocation test feed: `devices`
// rotary encoders on one bus at node-IDs 1..devices, with the rotary default
// TPDO1 mapping (J§1.7.2: position INTEGER32, speed INTEGER16).
// Caller's thread only (set-up, before the measured loop).
#pragma once

#include "pipeline/bus_receiver.hpp"
#include "pipeline/plugin_host.hpp"

#include <string>
#include <vector>

namespace cobridge::bench {

// Publishes one decode plan per device; false (and `err`) if a mapping is refused.
inline bool publish_rotary_fleet(pipeline::DeviceTable& table, int devices, std::string& err) {
  for (int n = 1; n <= devices; ++n) {
    pipeline::DecodePlan p;
    p.active = true;
    p.indexed = true;
    p.node_id = static_cast<std::uint8_t>(n);
    p.device_index = static_cast<std::uint16_t>(n - 1);
    const std::vector<pipeline::MappedObject> map = {{0x60200120, true}, {0x60300110, true}};
    if (!pipeline::build_pdo_decode(map, p.tpdo[0], err)) return false;
    table.publish(p);
  }
  return true;
}

// Announces the same devices to the plugins (COBRIDGE_DEVICE_ADDED).
inline void announce_rotary_fleet(pipeline::PluginHost& host, int devices) {
  for (int n = 1; n <= devices; ++n) {
    cobridge_device_info info{};
    info.struct_size = sizeof info;
    info.device_index = static_cast<std::uint16_t>(n - 1);
    info.node_id = static_cast<std::uint8_t>(n);
    info.change = COBRIDGE_DEVICE_ADDED;
    const std::string name = "enc" + std::to_string(n);
    info.name = name.c_str();
    info.bus_name = "vcan0";
    info.model = "RFC-4800";
    info.family = "novotechnik-rotary";
    info.position_unit = "counts";
    host.announce(info);
  }
}

}  // namespace cobridge::bench
