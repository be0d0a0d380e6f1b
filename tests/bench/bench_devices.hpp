// The benches' devices as a plugin sees them: `count` devices, eight per bus
// at node-IDs 1..8, announced ADDED through the plugin host (ABI on_device).
// The bench's own thread, before it feeds samples. A template on the host
// (pipeline::PluginHost): this folder's own library links no layer.
#pragma once

#include <cobridge/plugin.h>

#include <cstdint>
#include <functional>
#include <string>

namespace cobridge::bench {

template <typename Host>
void announce_devices(Host& host, unsigned count, const std::function<std::string(unsigned)>& name_of) {
  for (unsigned d = 0; d < count; ++d) {
    cobridge_device_info info{};
    info.struct_size = sizeof info;
    info.device_index = static_cast<std::uint16_t>(d);
    info.bus_index = static_cast<std::uint8_t>(d / 8);
    info.node_id = static_cast<std::uint8_t>(1 + d % 8);
    info.change = COBRIDGE_DEVICE_ADDED;
    const std::string name = name_of(d);
    info.name = name.c_str();
    info.bus_name = info.model = info.family = info.position_unit = "";
    host.announce(info);
  }
}

}  // namespace cobridge::bench
