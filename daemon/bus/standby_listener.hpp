// StandbyListener: what the standby of a hot-standby pair learns from the
// master's traffic alone, one frame at a time. It sends nothing and knows
// no device: the controller (bus_controller_standby.cpp) applies what it
// hears to the configured devices.
//
// From the bus it learns:
//   - a node's NMT state from its heartbeat (CiA 301 7.2.8.3.2), so the
//     standby's status shows a device the master configured as operational;
//   - a node's identity from the master's expedited SDO uploads of the
//     identity object 0x1018 (CiA 301 7.5.2.36: sub 1 vendor, 2 product,
//     3 revision, 4 serial): the COB-ID names the node, so a device the
//     master commissioned with LSS is known here by its serial. Only the
//     answer to an upload request seen on the bus, for that sub-index and
//     within the SDO timeout, counts: an answer nobody asked for (any node
//     can send one) is ignored, so a forged frame cannot place a device.
// Control thread only.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>

#include "can/frame.hpp"
#include "canopen/lss.hpp"
#include "canopen/clock.hpp"

namespace cobridge::bus {

class StandbyListener {
 public:
  struct Heard {
    enum class Kind : std::uint8_t {
      nothing,   // a frame that tells a standby nothing
      state,     // `node`'s heartbeat: `operational` or not
      identity,  // `node` answered the fourth identity upload: `identity` complete
    };
    Kind kind = Kind::nothing;
    std::uint8_t node = 0;
    bool operational = false;
    canopen::LssAddress identity{};
  };

  // One frame of the bus, received at `now`; `sdo_timeout`: how long after
  // its request an upload's answer counts (the bus's sdo_timeout_ms).
  Heard hear(const can::Frame& frame, canopen::TimePoint now, std::chrono::milliseconds sdo_timeout) noexcept;

 private:
  // Per node: the 0x1018 sub-index of the upload seen requested (0: none)
  // and when.
  struct Asked {
    std::uint8_t sub = 0;
    canopen::TimePoint at{};
  };
  Heard heartbeat(const can::Frame& frame) const noexcept;
  void request(const can::Frame& frame, canopen::TimePoint now) noexcept;
  Heard answer(const can::Frame& frame, canopen::TimePoint now, std::chrono::milliseconds sdo_timeout) noexcept;

  std::array<canopen::LssAddress, 128> identity_{};  // per node, what the answers gave so far
  std::array<Asked, 128> asked_{};
};

}  // namespace cobridge::bus
