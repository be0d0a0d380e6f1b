// DaemonRoute: `cobridge sdo|nmt|lss` while cobridged owns the bus.
//
// A second master on a bus the daemon serves would share the node's SDO
// channel with the daemon's own client (CiA 301 allows one), run LSS
// sessions the daemon does not know about and send NMT it does not hear of.
// So these commands first ask the daemon's control socket to run them with
// its own SDO client / NMT / LSS master (control_request.hpp); only when no
// daemon listens, or the daemon serves no bus on that interface, does the
// command open the interface itself, as before.
//
// Failures, from the daemon or from the command's own work, are one
// cobridge::Error: printed as "cobridge: <what>: <where>: <message>" (or, with
// --json, as {"ok":false,"error":{...}} on stdout), and the exit code is
// exit_code(kind) (docs/operations.md, "Exit codes").
//
// Thread: the CLI's main thread; blocking I/O with a timeout.
#pragma once

#include "base/error.hpp"
#include "cli/json_value.hpp"

#include <functional>
#include <optional>
#include <string>

namespace cobridge::cli {

struct DaemonAnswer {
  Json doc;          // the daemon's answer ({"ok":true,...})
  std::string line;  // as received, for --json
};

// The control socket to ask about `iface`: that of the daemon serving it,
// found from the interface alone (sys/bus_beacon.hpp), whatever `control`
// says; else `control`. `owned`: a daemon serves `iface`. A beacon that does
// not answer sets `error` (the bus is not opened beside a daemon).
std::string control_for(const std::string& control, const std::string& iface, bool& owned, Error& error);

// Sends `line`, a command on interface `iface`, to the daemon serving it
// (control_for). nullopt: no daemon owns this bus (no beacon, and nothing
// listens at `control` or it serves no such interface): work directly. Else
// the answer, or the Error it carried (also a transport failure, and any
// failure to reach a daemon that serves `iface`).
std::optional<std::pair<Error, DaemonAnswer>> via_daemon(const std::string& control, const std::string& iface,
                                                         const std::string& line, int timeout_ms);

// The Error of a {"ok":false,"error":{...}} answer (also an older daemon's {"error":"..."}).
Error error_of_answer(const Json& doc);

// Prints a failure of command `what` (text on stderr, or JSON on stdout) and
// returns its exit code.
int report_failure(const char* what, const Error& error, bool json);
// The same for a failure the daemon answered: with --json its answer as it is.
int report_daemon_failure(const char* what, const std::pair<Error, DaemonAnswer>& routed, bool json);

// Sends `line` to the daemon at `control` and parses its JSON answer. On a
// failure (transport, garbage, {"ok":false}) prints it as report_failure
// does, sets `code` and returns nullopt; with `json` the answer is printed.
std::optional<Json> ask_daemon(const std::string& control, const std::string& line, const char* what, int timeout_ms,
                               bool json, int& code);

}  // namespace cobridge::cli
