// ControlRequest: one request line of the control socket, parsed. The line
// comes from any local process that may connect, so every byte sequence gets
// a request or an error that names what was wrong, never a crash.
//
//   status
//   commission [BUS]
//   sdo-read BUS NODE INDEX SUB [TIMEOUT_MS]          (INDEX hex, SUB decimal or 0x-hex)
//   sdo-write BUS NODE INDEX SUB HEXBYTES [TIMEOUT_MS] (the bytes as on the wire, e.g. E803 = 1000 as u16)
//   nmt BUS start|stop|preop|reset|reset-comm NODE     (NODE 0 = all nodes)
//   lss-set-node-id BUS VENDOR PRODUCT REVISION SERIAL NODE store|no-store [TIMEOUT_MS]
//   capture-now [BUS]                                  (a flight-recorder capture, cause "operator")
//   capture-get NAME                                   (a capture file's text)
//   acknowledge DEVICE                                 (its contested configuration may be written again)
//
// BUS is a bus name or its interface. `cobridge sdo|nmt|lss` send these
// while a daemon owns the bus.
//
// Thread: any; a pure function (allocates only for the texts).
#pragma once

#include "base/error.hpp"
#include "bus/service/service_request.hpp"

#include <string>
#include <string_view>

namespace cobridge::control {

struct ControlRequest {
  enum class Kind { invalid, status, commission, service, capture_now, capture_get, acknowledge } kind = Kind::invalid;
  std::string bus;        // commission, capture_now: the bus (empty = every bus); service: bus name or interface
  std::string name;       // capture_get: the capture's file name; acknowledge: the device
  bus::ServiceRequest command;  // service: what to run (tag and caller left for the server)
  Error error;            // invalid: kInvalidArgument with what is wrong, printable ASCII only
};

[[nodiscard]] ControlRequest parse_control_request(std::string_view line);

}  // namespace cobridge::control
