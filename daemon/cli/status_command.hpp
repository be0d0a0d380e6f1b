// `cobridge status` and `cobridge commission`: the CLI side of cobridged's
// control socket (control/control_server.hpp): one request line, one JSON
// answer line. `status` prints a table of buses and devices with the timed
// commissioning steps (or the daemon's JSON as it is with --json);
// `commission` asks the daemon to commission one bus or all of them now.
// Thread: the CLI's main thread; blocking I/O with a timeout.
#pragma once

#include <string>

namespace cobridge::cli {

struct StatusOptions {
  std::string control = "/run/cobridge/control.sock";
  bool json = false;
  int timeout_ms = 3000;
};

struct CommissionOptions {
  std::string control = "/run/cobridge/control.sock";
  std::string bus;  // empty = every bus
  bool json = false;
  int timeout_ms = 3000;
};

// Exit codes: 0 ok, 1 the daemon cannot be reached or refused.
int status(const StatusOptions& options);
int commission(const CommissionOptions& options);

}  // namespace cobridge::cli
