// ServiceAccess: who may reach the buses through the daemon, and how.
//
// Two paths lead to the daemon's SDO client, NMT and LSS master: the control
// socket (`cobridge sdo|nmt|lss` while cobridged runs) and the CiA 309-3
// ASCII gateway (`cocomm` and other 309-3 clients). Both are read-only unless
// their `writes_enabled` is set, as for Modbus. On the control socket a
// write (SDO download, NMT, LSS) is further limited to the members of
// `write_group` (checked with SO_PEERCRED).
//
// Thread contract: plain values, read by the loader and the daemon's main thread.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace cobridge::config {

// [control]
struct ControlAccess {
  bool writes_enabled = false;
  std::string write_group = "cobridge-admin";  // empty = any caller that may connect
};

// [ascii_gateway]
struct AsciiGatewaySettings {
  bool enabled = false;
  std::filesystem::path socket;    // Unix socket; empty = the control socket's directory + "ascii.sock"
  std::uint16_t tcp_port = 0;      // 0 = no TCP listener
  std::string bind = "127.0.0.1";  // the TCP listener's address
  bool writes_enabled = false;
  std::vector<std::string> write_allow;  // TCP: CIDR networks whose writes are taken; empty = every client
  std::string write_group = "cobridge-admin";  // Unix socket: root, the daemon's user and members write; "" = all
  std::uint32_t max_clients = 128;
  std::uint32_t sdo_timeout_ms = 1000;  // default per request ("set sdo_timeout" changes it per connection)
  std::string where;                    // "file:line:column" of the [ascii_gateway] header, for warnings
};

struct ServiceAccess {
  ControlAccess control;
  AsciiGatewaySettings ascii;
};

}  // namespace cobridge::config
