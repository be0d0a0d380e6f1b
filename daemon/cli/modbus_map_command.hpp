// `cobridge modbus-map`: prints the Modbus TCP output's register map, as CSV
// for SCADA import (--csv: address,name,type,unit,scale,access,description)
// or as a table. The map comes from plugins/modbus/register_map.hpp, the
// same definition the plugin serves from, so the export cannot drift.
// Thread: the CLI's main thread; no I/O but stdout.
#pragma once

namespace cobridge::cli {

struct ModbusMapOptions {
  bool csv = false;
  int devices = 32;  // device slots to list (the plugin's max_devices)
  int buses = 16;    // bus blocks to list
};

// Exit codes: 0 ok, 2 bad option values.
int modbus_map(const ModbusMapOptions& options);

}  // namespace cobridge::cli
