// `cobridge acknowledge DEVICE`: the operator's word that a device's
// contested configuration (an object another writer kept changing after
// three restores, bus/restore_guard.hpp) may be written again. Sent to
// cobridged's control socket (control/control_server.hpp), where it is a
// write under [control] writes_enabled / write_group, logged with the caller.
// Thread: the CLI's main thread; blocking I/O with a timeout.
#pragma once

#include <string>

namespace cobridge::cli {

struct AcknowledgeOptions {
  std::string control = "/run/cobridge/control.sock";
  std::string device;
  bool json = false;
  int timeout_ms = 3000;
};

// Exit codes as docs/operations.md "Exit codes" (the Error kinds).
int acknowledge(const AcknowledgeOptions& options);

}  // namespace cobridge::cli
