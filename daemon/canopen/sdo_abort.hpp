// SDO abort codes (CiA 301 §7.2.4.3.17, table "SDO abort codes") as std::error_code.
//
// The enum values ARE the 32-bit wire codes, so an error_code carrying one
// compares straight against the spec (`ec == SdoAbort::kSubIndexDoesNotExist`,
// `ec.value() == 0x06090011`) and goes back on the wire unchanged. Codes a
// server sends that the spec does not list still travel in the same category;
// their message is "unknown abort code".
// The three device manuals list a subset (J§1.6.3, E§7.3; F documents none);
// their wording is noted next to each code.
// Thread-safety: stateless; callable from any thread.
#pragma once

#include <cstdint>
#include <string_view>
#include <system_error>
#include <type_traits>

namespace cobridge::canopen {

enum class SdoAbort : uint32_t {
  kToggleBitNotAlternated = 0x05030000,
  kProtocolTimedOut = 0x05040000,
  kCommandSpecifierInvalid = 0x05040001,
  kInvalidBlockSize = 0x05040002,       // block mode only
  kInvalidSequenceNumber = 0x05040003,  // block mode only
  kCrcError = 0x05040004,               // block mode only
  kOutOfMemory = 0x05040005,
  kUnsupportedAccess = 0x06010000,
  kWriteOnly = 0x06010001,  // attempt to read a write-only object (J, E: "write only")
  kReadOnly = 0x06010002,   // attempt to write a read-only object (J, E: "read only")
  kObjectDoesNotExist = 0x06020000,       // J, E
  kObjectCannotBeMapped = 0x06040041,
  kPdoLengthExceeded = 0x06040042,
  kParameterIncompatible = 0x06040043,
  kInternalIncompatible = 0x06040047,
  kHardwareError = 0x06060000,            // J, E: "access error"
  kLengthMismatch = 0x06070010,
  kLengthTooHigh = 0x06070012,
  kLengthTooLow = 0x06070013,
  kSubIndexDoesNotExist = 0x06090011,     // J, E
  kInvalidValue = 0x06090030,             // J, E: "value exceeded" (older CiA name: value range exceeded)
  kValueTooHigh = 0x06090031,
  kValueTooLow = 0x06090032,
  kMaxLessThanMin = 0x06090036,
  kResourceNotAvailable = 0x060A0023,
  kGeneralError = 0x08000000,             // J, E
  kCannotStore = 0x08000020,              // J: "data transfer error", E: "data transport error"
  kCannotStoreLocalControl = 0x08000021,
  kCannotStoreDeviceState = 0x08000022,   // J: "unfair status" (sic), E: "wrong state"
  kNoObjectDictionary = 0x08000023,
  kNoDataAvailable = 0x08000024,
};

// Human-readable CiA 301 text for a wire code; "unknown abort code" for codes
// the spec does not define.
[[nodiscard]] std::string_view sdo_abort_text(uint32_t code) noexcept;

// True when `code` is one of the SdoAbort values above.
[[nodiscard]] bool is_known_sdo_abort(uint32_t code) noexcept;

// The category named "sdo_abort"; error values are the wire codes.
[[nodiscard]] const std::error_category& sdo_abort_category() noexcept;

[[nodiscard]] std::error_code make_error_code(SdoAbort code) noexcept;

// An error_code for any 32-bit code received on the wire. Code 0 is not an
// abort code (and would read as "success"), so it is reported as general error.
[[nodiscard]] std::error_code sdo_abort_error(uint32_t wire_code) noexcept;

// The wire code to send for an error: its value if it is an sdo_abort error,
// general error (0x08000000) for anything else.
[[nodiscard]] uint32_t sdo_abort_wire_code(const std::error_code& ec) noexcept;

}  // namespace cobridge::canopen

template <>
struct std::is_error_code_enum<cobridge::canopen::SdoAbort> : std::true_type {};
