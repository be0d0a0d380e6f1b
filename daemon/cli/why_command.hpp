// `cobridge why DEVICE`: the chain of events that led to a device's present
// state, from its timeline in the daemon's status document (bus/
// device_timeline.hpp), each with the flight recorder's capture that holds
// its frames (`cobridge capture get NAME` prints them).
//
// The chain: for a device that is not operational, what happened since it
// was last operational; for an operational one, its way back since it last
// left that state (its whole timeline when it never did). --all prints the
// whole timeline (at most 100 events).
// Thread: the CLI's main thread; blocking I/O with a timeout.
#pragma once

#include "cli/json_value.hpp"

#include <cstddef>
#include <string>
#include <string_view>

namespace cobridge::cli {

struct WhyOptions {
  std::string control = "/run/cobridge/control.sock";
  std::string device;  // a configured name, or BUS:NODE
  bool all = false;
  bool json = false;
  int timeout_ms = 10000;
};

// The index of the chain's first event in `timeline` (a JSON array of the
// status document's events, oldest first) for a device in `state`.
[[nodiscard]] std::size_t chain_start(const Json& timeline, std::string_view state);

// Exit codes as docs/operations.md "Exit codes": 0, or 6 (not found) for a
// device the daemon does not know.
int why(const WhyOptions& options);

}  // namespace cobridge::cli
