// `cobridge sdo read|write`: one SDO transfer to one node on a bus.
#pragma once

#include "base/error.hpp"

#include <cstdint>
#include <string>

namespace cobridge::cli {

struct SdoOptions {
  std::string iface;
  unsigned node = 0;
  std::string object;        // "0x1018:4" or "0x6004" (sub 0)
  std::string value;         // write: decimal, 0x-hex, or text with --string
  unsigned size = 0;         // write: 1, 2 or 4 bytes (0 = 4 for numbers)
  bool as_string = false;    // read: print as text; write: send text bytes
  unsigned timeout_ms = 500;
  bool json = false;
  std::string control = "/run/cobridge/control.sock";  // the daemon that may own the bus
};

// Parses "0xIIII[:SS]" / "IIII:SS" (hex index, sub decimal or 0x-hex); a
// failure is kInvalidArgument with where "object '<text>'".
[[nodiscard]] Error parse_object(const std::string& text, uint16_t& index, uint8_t& sub);

// Through the daemon when it owns the bus (daemon_route.hpp), else on the
// interface directly. Exit codes: exit_code(Errc) (docs/operations.md).
int sdo_read(const SdoOptions& o);
int sdo_write(const SdoOptions& o);

}  // namespace cobridge::cli
