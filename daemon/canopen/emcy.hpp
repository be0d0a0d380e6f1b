// EMCY: the CiA 301 emergency message (§7.2.7), its code classes and error
// register bits: the standard's part. What a device family's manual says its
// codes mean is in that family's module (daemon/families, EmcyTable);
// device/emcy_meaning combines the two.
//
// A frame is `code_lo code_hi error_register b3 b4 b5 b6 b7` on 0x80 + node
// (object 0x1014). Decoding and encoding are noexcept and allocation-free for
// the bus RX thread; the texts are static.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

#include "can/frame.hpp"

namespace cobridge::canopen {

struct Emcy {
  uint16_t error_code = 0;
  uint8_t error_register = 0;
  std::array<uint8_t, 5> manufacturer{};  // frame bytes 3..7

  friend constexpr bool operator==(const Emcy&, const Emcy&) = default;
};

enum class EmcyFrameError : uint8_t {
  none = 0,
  wrong_cob_id,    // not 0x81..0xFF (0x80 itself is SYNC)
  wrong_length,    // CiA 301 §7.2.7.3.1: an EMCY has exactly 8 data bytes
  remote_request,
  extended_id,
};
[[nodiscard]] std::string_view to_string(EmcyFrameError error) noexcept;

struct EmcyParse {
  EmcyFrameError error = EmcyFrameError::none;
  uint8_t node = 0;  // 0 when decoded without a COB-ID check
  Emcy emcy;
  [[nodiscard]] constexpr bool ok() const noexcept { return error == EmcyFrameError::none; }
};

// A frame on the predefined EMCY COB-ID 0x80 + 1..127.
[[nodiscard]] EmcyParse parse_emcy(const can::Frame& frame) noexcept;
// The payload only, for a COB-ID the caller already matched (0x1014 is
// writable on ifm devices, F§7.3).
[[nodiscard]] EmcyParse decode_emcy(const can::Frame& frame) noexcept;

[[nodiscard]] can::Frame make_emcy(uint8_t node, const Emcy& emcy) noexcept;
[[nodiscard]] can::Frame make_emcy_on(uint32_t cob_id, const Emcy& emcy) noexcept;

// CiA 301 §7.2.7.1 error codes named in the standard (specific codes of
// the 0x81xx/0x82xx monitoring group), as wire values.
namespace emcy_code {
inline constexpr uint16_t kErrorReset = 0x0000;
inline constexpr uint16_t kGeneric = 0x1000;
inline constexpr uint16_t kDeviceHardware = 0x5000;
inline constexpr uint16_t kDeviceSoftware = 0x6000;
inline constexpr uint16_t kCanOverrun = 0x8110;
inline constexpr uint16_t kCanErrorPassive = 0x8120;
inline constexpr uint16_t kLifeGuardHeartbeat = 0x8130;
inline constexpr uint16_t kBusOffRecovered = 0x8140;
inline constexpr uint16_t kCanIdCollision = 0x8150;
inline constexpr uint16_t kPdoLengthError = 0x8210;
inline constexpr uint16_t kPdoLengthExceeded = 0x8220;
inline constexpr uint16_t kUnexpectedSyncLength = 0x8240;
inline constexpr uint16_t kExternal = 0x9000;
// CiA 301 §7.2.7.1 codes of the voltage and temperature classes.
inline constexpr uint16_t kSupplyVoltage = 0x3100;
inline constexpr uint16_t kDeviceTemperature = 0x4210;
}  // namespace emcy_code

// The CiA 301 text of a code: the specific code if the standard names it,
// otherwise its class (0x2xxx current, 0x81xx communication, ...).
[[nodiscard]] std::string_view cia301_text(uint16_t error_code) noexcept;

// CiA 301 object 0x1001 bits.
enum class ErrorRegisterBit : uint8_t {
  generic = 0x01,
  current = 0x02,
  voltage = 0x04,
  temperature = 0x08,
  communication = 0x10,
  device_profile = 0x20,
  reserved = 0x40,
  manufacturer = 0x80,
};
[[nodiscard]] std::string_view to_string(ErrorRegisterBit bit) noexcept;
// "generic|communication", or "none". Allocates.
[[nodiscard]] std::string error_register_text(uint8_t error_register);

// CiA 406 object 0x6400 (work area state) bits as text: "inside", or
// "out of range|overflow|underflow". Allocates.
[[nodiscard]] std::string work_area_state_text(uint8_t state);

}  // namespace cobridge::canopen
