// `cobridge lss set-node-id`: give one device, addressed by its full LSS
// identity (CiA 305 switch state selective), a node-ID and store it.
#pragma once

#include <cstdint>
#include <string>

namespace cobridge::cli {

struct LssSetNodeOptions {
  std::string iface;
  uint32_t vendor = 0, product = 0, revision = 0, serial = 0;
  unsigned node = 0;
  bool store = true;
  unsigned timeout_ms = 100;
  bool json = false;
  std::string control = "/run/cobridge/control.sock";  // the daemon that may own the bus
};
// Through the daemon when it owns the bus (discovery waits meanwhile, and the
// stored node-ID goes to its state file); else on the interface.

int lss_set_node_id(const LssSetNodeOptions& o);

}  // namespace cobridge::cli
