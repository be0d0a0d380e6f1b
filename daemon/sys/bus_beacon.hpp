// BusBeacon: how a running cobridged is found from the name of a CAN
// interface it serves, whatever its control socket's path.
//
// A CLI that opened the interface beside a running daemon would be a second
// CANopen master (its own SDO client on the node's one SDO channel, NMT and
// LSS the daemon never hears of). The daemon therefore listens, for each
// interface it serves, on the abstract Unix socket "cobridge/bus/<iface>".
// Abstract names need no file, no directory that must match, vanish with
// the process (no stale lock after a crash) and live in the network
// namespace, as CAN interfaces do. A client that connects reads one line,
//
//     cobridged <pid> <control socket path>\n
//
// and is closed; the CLI then talks to that control socket, or, if it may
// not, refuses instead of opening the bus itself. The name is not a secret
// and gives nothing: the control socket keeps its own mode and write policy.
//
// Threads: a BusBeacon is opened, polled and served by the daemon's main
// thread; find_bus_owner() by the CLI's main thread (blocking, bounded).
#pragma once

#include "base/error.hpp"

#include <sys/types.h>

#include <optional>
#include <string>
#include <string_view>

namespace cobridge::sys {

// The abstract socket name (without the leading NUL) for `iface`.
[[nodiscard]] std::string bus_beacon_name(std::string_view iface);

class BusBeacon {
 public:
  BusBeacon() = default;
  ~BusBeacon();
  BusBeacon(BusBeacon&& other) noexcept;
  BusBeacon& operator=(BusBeacon&& other) noexcept;
  BusBeacon(const BusBeacon&) = delete;
  BusBeacon& operator=(const BusBeacon&) = delete;

  // Listens for `iface`. kUnavailable (the message names the other daemon's
  // pid and control socket) when another process already serves it.
  [[nodiscard]] Error open(std::string_view iface, const std::string& control_path);
  [[nodiscard]] int fd() const noexcept { return fd_; }
  // Answers every waiting client; never blocks.
  void serve() noexcept;
  void close() noexcept;

 private:
  int fd_ = -1;
  std::string line_;
};

struct BusOwner {
  pid_t pid = 0;
  std::string control;  // its control socket's path
};

// The daemon serving `iface`, nothing when none does. An owner that does not
// answer within `timeout_ms` is an error (kUnavailable), never "none".
[[nodiscard]] std::optional<BusOwner> find_bus_owner(std::string_view iface, int timeout_ms, Error& error);

}  // namespace cobridge::sys
