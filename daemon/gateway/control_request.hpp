// ControlRequest: one request line of the control socket (`cobridge status`,
// `cobridge commission [BUS]`), parsed. The line comes from any local process
// that may connect, so every byte sequence gets a request or an error that
// names what was wrong, never a crash.
// Thread: any; a pure function (allocates only for the error text).
#pragma once

#include <string>
#include <string_view>

namespace cobridge::gateway {

struct ControlRequest {
  enum class Kind { invalid, status, commission } kind = Kind::invalid;
  std::string bus;    // commission: the bus to commission; empty = every bus
  std::string error;  // invalid: what is wrong, printable ASCII only
};

[[nodiscard]] ControlRequest parse_control_request(std::string_view line);

}  // namespace cobridge::gateway
