// `cobridge capture list|now|get`: the flight recorder's captures through
// cobridged's control socket (control/control_server.hpp). `list` reads the
// status document's "recorder" of each bus; `now` asks for a capture with
// cause "operator"; `get` prints a capture file (candump -l log) or writes
// it to a file.
// Thread: the CLI's main thread; blocking I/O with a timeout.
#pragma once

#include <string>

namespace cobridge::cli {

struct CaptureOptions {
  enum class Verb { list, now, get } verb = Verb::list;
  std::string control = "/run/cobridge/control.sock";
  std::string bus;     // now: empty = every bus
  std::string name;    // get
  std::string output;  // get: empty = standard output
  bool json = false;
  int timeout_ms = 10000;
};

// Exit codes as docs/operations.md "Exit codes" (the Error kinds).
int capture(const CaptureOptions& options);

}  // namespace cobridge::cli
