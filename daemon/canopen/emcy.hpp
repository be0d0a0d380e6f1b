// EMCY: the CiA 301 emergency message (§7.2.7), its code classes and error
// register bits, and what the three encoder manuals say their codes mean.
//
// A frame is `code_lo code_hi error_register b3 b4 b5 b6 b7` on 0x80 + node
// (object 0x1014). Decoding and encoding are noexcept and allocation-free for
// the bus RX thread. `classify()` is noexcept too and returns static text;
// only `describe()` builds a std::string and belongs off the hot path (the
// log line of the gateway, the simulator's UI).
//
// The vendors do not all use the bytes after the code the same way:
//  * Novotechnik rotary (J§1.8.1): byte 2 is the CiA error register (always 1
//    when an error is active); bytes 3-4, 5-6 and 7 carry the details.
//  * Novotechnik multiturn (E§9.1): byte 2 (0/1/2) and byte 3 together form a
//    sub-code, and every row has a level Info/Warn/Error/Hard that 0x2104
//    filters. Such frames are decoded by (code, byte 2, byte 3), not by the
//    CiA meaning of the error-register bits.
//  * ifm RM (F§4, F§7.3 0x1003): one EMCY object, but no code table at all;
//    only the CiA 301 classes can be given.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
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
// Manufacturer codes used by Novotechnik (J§1.8.1, E§9.1).
inline constexpr uint16_t kNovotechnikCam = 0x9080;
inline constexpr uint16_t kNovotechnikWorkArea = 0x9090;
inline constexpr uint16_t kNovotechnikMeasurement = 0x5051;
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

enum class DeviceFamily : uint8_t { generic, novotechnik_rotary, ifm_rm, novotechnik_multiturn };
[[nodiscard]] std::string_view to_string(DeviceFamily family) noexcept;

// E§9.1 "Level"; the other manuals define none.
enum class EmcyLevel : uint8_t { unspecified, info, warn, error, hard };
[[nodiscard]] std::string_view to_string(EmcyLevel level) noexcept;

struct EmcyInfo {
  std::string_view text;       // the manual's meaning, else the CiA 301 text
  std::string_view source;     // "J§1.8.1", "E§9.1" or "CiA 301"
  EmcyLevel level = EmcyLevel::unspecified;
  bool from_manual = false;    // a row of the family's own table matched
  bool error_reset = false;    // announces that the error condition is gone
  std::optional<int32_t> position_value;  // what the position reads meanwhile (E§9.1)
};
[[nodiscard]] EmcyInfo classify(DeviceFamily family, const Emcy& emcy) noexcept;

// One log line: code, meaning, source, level and the decoded detail bytes
// (channel, CAMs, work-area state). Allocates; off the hot path.
[[nodiscard]] std::string describe(DeviceFamily family, const Emcy& emcy);

// Error position values (J§1.8 and E§9.1): what a position object reads
// while an error is active. nullopt when `position` is an ordinary value.
inline constexpr int32_t kRotaryErrorPosition = 0x7FF0;
inline constexpr int32_t kMultiturnErrorPosition = 0x7FFFFFFC;
inline constexpr int32_t kMultiturnOverflowPosition = 0x7FFFFFF8;
inline constexpr int32_t kMultiturnUnderflowPosition = -2147483640;  // 0x80000008
[[nodiscard]] std::optional<std::string_view> error_position_meaning(DeviceFamily family,
                                                                     int32_t position) noexcept;

// Builders for the frames whose detail bytes carry data, so the simulator
// does not have to know the byte positions.
// J§1.8.1 0x9080: bytes 3-4 channel, bytes 5-6 CAMs, byte 7 new 0x6300 value.
[[nodiscard]] Emcy rotary_cam_emcy(uint16_t channel, uint16_t cams, uint8_t state) noexcept;
// J§1.8.1 0x9090: bytes 3-4 channel, byte 7 new 0x6400 value.
[[nodiscard]] Emcy rotary_work_area_emcy(uint16_t channel, uint8_t state) noexcept;
// E§9.1 0x9080: byte 4 changed CAMs 1-4, byte 7 CAM state bits.
[[nodiscard]] Emcy multiturn_cam_emcy(uint8_t changed, uint8_t state) noexcept;
// E§9.1 0x9090: byte 7 work-area state.
[[nodiscard]] Emcy multiturn_work_area_emcy(uint8_t state) noexcept;

}  // namespace cobridge::canopen
