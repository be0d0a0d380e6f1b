// Texts about identities, shared by every part of discovery's events.
#include "bus/discovery/bus_picture.hpp"

#include <cstdio>

namespace cobridge::gateway::discovery {

std::string hex32(std::uint32_t v) {
  char b[16];
  std::snprintf(b, sizeof b, "0x%08X", v);
  return b;
}

std::string describe(const LssAddress& a) {
  return "vendor " + hex32(a.vendor) + " product " + hex32(a.product) + " revision " + hex32(a.revision) +
         " serial " + std::to_string(a.serial);
}

}  // namespace cobridge::gateway::discovery
