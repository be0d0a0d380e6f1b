// ServiceRequest: one CAN operation a client asks the daemon to run on one of
// its buses with the daemon's own SDO client, NMT and LSS master: the CLI
// through the control socket (`cobridge sdo|nmt|lss` while cobridged runs)
// and CiA 309-3 clients through the ASCII gateway. The daemon stays the one
// master of the bus: the bus manager's control thread runs these commands
// between its own work, never on a node it is configuring.
//
// ServiceResult is the outcome, delivered through ServiceReplies to the
// thread that owns the client's connection, which writes the answer.
//
// Thread contract: plain values, nothing of the client's connection; built
// on the main thread (control socket, ASCII gateway), executed on the bus's
// control thread.
#pragma once

#include "base/error.hpp"
#include "canopen/lss.hpp"
#include "canopen/nmt.hpp"

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace cobridge::bus {

enum class ServiceOp : std::uint8_t {
  sdo_upload,    // read index:sub of `node`
  sdo_download,  // write `data` to index:sub of `node`
  nmt,           // send `nmt` to `node` (0 = all nodes)
  lss,           // run `lss_steps` in order (discovery waits meanwhile)
};

// One step of an LSS command (CiA 305 services).
struct LssStep {
  enum class Kind : std::uint8_t {
    switch_global,     // value: 0 waiting, 1 configuration
    switch_selective,  // address
    set_node_id,       // value: 1..127 or 0xFF
    store,
    inquire_vendor,
    inquire_product,
    inquire_revision,
    inquire_serial,
    inquire_node_id,
  } kind = Kind::switch_global;
  canopen::LssAddress address{};
  std::uint32_t value = 0;
};

struct ServiceRequest {
  ServiceOp op = ServiceOp::sdo_upload;
  std::uint8_t node = 0;
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::vector<std::uint8_t> data;  // sdo_download
  canopen::NmtCommand nmt = canopen::NmtCommand::start;
  std::vector<LssStep> lss_steps;
  // The device's answer window per SDO request (CiA 301 leaves it to the application).
  std::chrono::milliseconds sdo_timeout{500};
  // The whole command, waiting for the node included (a node being
  // configured or rebooting is waited for, not interrupted).
  std::chrono::milliseconds deadline{10000};
  std::uint64_t tag = 0;  // the submitter's, echoed in the result
  std::string caller;     // "uid 1000 pid 42 (control socket)", for the log of writes

  [[nodiscard]] bool is_write() const noexcept { return op != ServiceOp::sdo_upload; }
};

struct ServiceResult {
  std::uint64_t tag = 0;
  Error error;                     // kOk on success
  std::uint32_t abort_code = 0;    // the CiA 301 SDO abort code when the device refused
  std::vector<std::uint8_t> data;  // sdo_upload: the value as read
  std::uint32_t value = 0;         // lss: the last inquired value
  std::vector<std::uint32_t> values;  // lss: every inquired value, in order
};

[[nodiscard]] const char* to_string(ServiceOp op) noexcept;

}  // namespace cobridge::bus
