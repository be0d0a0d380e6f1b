// What the configuration tests of one table start from: a gateway with one
// bus (and its node pool), and every diagnostic of a load as "line: message"
// lines for a failed assertion's message.
#pragma once

#include "config/load.hpp"

#include <string>

namespace cobridge::config::test {

inline const std::string kOneBus =
    "[gateway]\nid = \"t\"\nstate_dir = \"/tmp/x\"\ncontrol_socket = \"/run/x/control.sock\"\n"
    "[[bus]]\nname = \"line1\"\ninterface = \"vcan0\"\nnode_pool = [40, 41]\n";

inline std::string all_diagnostics(const LoadResult& r) {
  std::string s;
  for (const auto& d : r.diagnostics()) s += std::to_string(d.line) + ": " + d.message + "\n";
  return s;
}

}  // namespace cobridge::config::test
