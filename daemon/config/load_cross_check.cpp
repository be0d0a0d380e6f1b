// The checks across sections: names, node-IDs and serial numbers that must
// be unique, and buses that devices name.
#include "config/loader.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <map>
#include <system_error>

namespace cobridge::config::detail {

// ---- checks across sections ---------------------------------------------

void Loader::cross_check() {
  const std::map<std::string, std::size_t> bus_by_name = check_buses();
  check_devices(bus_by_name);
  check_serials();
}

// Bus names and interfaces are unique; returns the buses by name.
std::map<std::string, std::size_t> Loader::check_buses() {
  std::map<std::string, std::size_t> bus_by_name;
  std::map<std::string, std::size_t> bus_by_interface;
  for (std::size_t i = 0; i < config_.buses.size(); ++i) {
    const Bus& b = config_.buses[i];
    const BusSpots& s = bus_spots_[i];
    if (s.has_name) {
      auto [it, fresh] = bus_by_name.emplace(b.name, i);
      if (!fresh) {
        add(s.name, "duplicate bus name " + in_quotes(b.name) + " (first defined at " + at(bus_spots_[it->second].name) + ")");
      }
    }
    if (s.has_interface) {
      auto [it, fresh] = bus_by_interface.emplace(b.interface, i);
      if (!fresh) {
        add(s.interface, "bus " + in_quotes(b.name) + ": interface " + in_quotes(b.interface) + " is already used by bus " +
                             in_quotes(config_.buses[it->second].name) + " (" + at(bus_spots_[it->second].interface) + ")");
      }
    }
  }
  return bus_by_name;
}

// Device names are unique, each names a defined bus (its bus_index is set
// here), and node-IDs are unique per bus.
void Loader::check_devices(const std::map<std::string, std::size_t>& bus_by_name) {
  std::map<std::string, std::size_t> device_by_name;
  std::map<std::pair<std::size_t, std::uint8_t>, std::size_t> device_by_node;
  for (std::size_t i = 0; i < config_.devices.size(); ++i) {
    Device& d = config_.devices[i];
    const DeviceSpots& s = device_spots_[i];
    const std::string ctx = "device " + in_quotes(d.name) + ": ";
    if (s.has_name) {
      auto [it, fresh] = device_by_name.emplace(d.name, i);
      if (!fresh) {
        add(s.name, "duplicate device name " + in_quotes(d.name) + " (first defined at " +
                        at(device_spots_[it->second].name) + ")");
      }
    }
    if (!s.has_bus) continue;
    const auto bus = bus_by_name.find(d.bus);
    if (bus == bus_by_name.end()) {
      std::string names;
      for (const auto& [name, index] : bus_by_name) names += (names.empty() ? "" : ", ") + name;
      add(s.bus, ctx + "bus " + in_quotes(d.bus) + " is not defined (defined buses: " + (names.empty() ? "none" : names) + ")");
      continue;
    }
    d.bus_index = bus->second;
    if (d.node_id) {
      auto [it, fresh] = device_by_node.emplace(std::make_pair(d.bus_index, *d.node_id), i);
      if (!fresh) {
        add(s.node_id, ctx + "node_id " + std::to_string(*d.node_id) + " is already used by device " +
                           in_quotes(config_.devices[it->second].name) + " on bus " + in_quotes(d.bus) + " (" +
                           at(device_spots_[it->second].node_id) + ")");
      }
    }
  }
}

// Serial numbers are unique per vendor (CiA 301 0x1018): the same serial is
// a conflict unless both vendors are known and differ.
void Loader::check_serials() {
  for (std::size_t i = 0; i < config_.devices.size(); ++i) {
    const Device& d = config_.devices[i];
    if (!device_spots_[i].has_serial) continue;
    for (std::size_t j = 0; j < i; ++j) {
      const Device& first = config_.devices[j];
      if (!device_spots_[j].has_serial || first.serial != d.serial) continue;
      const auto va = vendor_of(d);
      const auto vb = vendor_of(first);
      if (va && vb && *va != *vb) continue;
      add(device_spots_[i].serial, "device " + in_quotes(d.name) + ": serial " + std::to_string(d.serial) +
                                       " is already used by device " + in_quotes(first.name) + " (" +
                                       at(device_spots_[j].serial) + ")");
      break;
    }
  }
}

std::optional<std::uint32_t> Loader::vendor_of(const Device& d) {
  if (d.vendor) return d.vendor;
  if (const KnownModel* m = find_model(d.model)) return m->vendor;
  return std::nullopt;
}

}  // namespace cobridge::config::detail
