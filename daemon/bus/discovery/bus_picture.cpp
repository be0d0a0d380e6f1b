// Texts about identities, shared by every part of discovery's events.
#include "bus/discovery/bus_picture.hpp"

#include "base/number_text.hpp"

namespace cobridge::bus::discovery {

std::string describe(const LssAddress& a) {
  return "vendor " + hex(a.vendor, 8) + " product " + hex(a.product, 8) + " revision " + hex(a.revision, 8) +
         " serial " + std::to_string(a.serial);
}

}  // namespace cobridge::bus::discovery
