// `cobridge nmt COMMAND NODE|all`: one NMT command frame (CiA 301 §7.2.8.3.1).
#pragma once

#include <string>

namespace cobridge::cli {

struct NmtOptions {
  std::string iface;
  std::string command;  // start | stop | preop | reset | reset-comm
  std::string node;     // 1..127 or "all"
  bool json = false;
  std::string control = "/run/cobridge/control.sock";  // the daemon that may own the bus
};
// Through the daemon when it owns the bus (daemon_route.hpp), which then
// knows the device was stopped / reset on purpose; else on the interface.

int nmt_send(const NmtOptions& o);

}  // namespace cobridge::cli
