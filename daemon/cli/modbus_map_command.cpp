#include "cli/modbus_map_command.hpp"

#include "register_map.hpp"

#include <cstdint>
#include <cstdio>
#include <string>

namespace cobridge::cli {

int modbus_map(const ModbusMapOptions& options) {
  using namespace cobridge::modbus;
  if (options.devices < 0 || options.devices > kMaxDeviceSlots || options.buses < 0 || options.buses > kMaxBuses) {
    std::fprintf(stderr, "modbus-map: --devices must be 0..%u and --buses 0..%u\n", unsigned{kMaxDeviceSlots},
                 unsigned{kMaxBuses});
    return 2;
  }
  const auto buses = static_cast<std::uint16_t>(options.buses);
  const auto devices = static_cast<std::uint16_t>(options.devices);
  if (options.csv) {
    const std::string csv = map_csv(buses, devices);
    std::fwrite(csv.data(), 1, csv.size(), stdout);
    return 0;
  }
  std::printf("Modbus register map v%u (holding and input registers alike; 32-bit values: word order per the\n"
              "plugin's word_order, default big = high word first). Device slot n at %u + %u*n.\n\n",
              unsigned{kMapVersion}, unsigned{kDeviceBase}, unsigned{kDeviceStride});
  std::printf("%-7s %-30s %-7s %-13s %-6s %-3s %s\n", "address", "name", "type", "unit", "scale", "acc", "description");
  for (const MapRow& row : map_rows(buses, devices)) {
    std::printf("%-7u %-30s %-7s %-13s %-6g %-3s %s\n", unsigned{row.address}, row.name.c_str(),
                type_name(row.def->type), row.def->unit, row.def->scale, access_name(row.def->access),
                row.def->description);
  }
  return 0;
}

}  // namespace cobridge::cli
