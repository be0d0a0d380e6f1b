// IdentityReader: reads a device's identity object 0x1018/1..4 (vendor-ID,
// product code, revision, serial number; CiA 301 §7.5.2.24) by SDO upload,
// as a non-blocking state machine like the protocol components.
//
// Used where discovery does not run (a bus with `discovery = false`): before
// a configured device is configured at its configured node-ID, the gateway
// makes sure the device there is the one the configuration names.
//
// Thread: the bus manager's control thread, which owns the SDO client; no
// clock reads, no allocation after construction.
#pragma once

#include <cstdint>
#include <optional>
#include <system_error>

#include "base/error.hpp"
#include "can/frame.hpp"
#include "canopen/clock.hpp"
#include "canopen/lss.hpp"
#include "canopen/sdo_client.hpp"

namespace cobridge::bus {

class IdentityReader {
 public:
  // `sdo` must outlive the reader and be addressed to the device's node-ID;
  // a reader dropped mid-transfer releases it.
  explicit IdentityReader(canopen::SdoClient& sdo) noexcept : sdo_(sdo) {}
  ~IdentityReader();
  IdentityReader(const IdentityReader&) = delete;
  IdentityReader& operator=(const IdentityReader&) = delete;

  // Starts with 0x1018/1; an error (kUnavailable: the SDO client is busy)
  // means nothing was sent.
  [[nodiscard]] Error start(canopen::TimePoint now);
  // Feeds a received frame; true when it was the SDO client's.
  bool on_frame(const can::Frame& frame, canopen::TimePoint now) noexcept;
  // Timeouts; returns the next deadline (kNever when finished).
  canopen::TimePoint process(canopen::TimePoint now) noexcept;

  [[nodiscard]] bool finished() const noexcept { return done_; }
  // Once finished: the identity, or the SDO error that ended the read
  // (serial 0 when the device has no 0x1018/4: it is optional in CiA 301).
  [[nodiscard]] const std::optional<canopen::LssAddress>& identity() const noexcept { return identity_; }
  [[nodiscard]] std::error_code error() const noexcept { return error_; }

 private:
  void next(canopen::TimePoint now);
  void collect(canopen::TimePoint now);

  canopen::SdoClient& sdo_;
  std::uint8_t sub_ = 0;
  bool running_ = false;
  bool done_ = false;
  canopen::LssAddress read_{};
  std::optional<canopen::LssAddress> identity_;
  std::error_code error_;
};

}  // namespace cobridge::bus
