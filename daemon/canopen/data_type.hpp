// DataType: the CiA 301 static data types (CiA 301 §7.4.7.1), with the facts
// every layer needs about them: size on the bus, signedness, the name used in
// EDS files and the manuals' tables.
//
// The enum values are the object-dictionary type indices, as written in EDS
// files (DataType=0x0007); 0x000E and 0x0017 are reserved and have no
// enumerator. The object dictionary stores a subset of these types; the EDS
// parser accepts all of them.
//
// Thread: pure constexpr functions, callable from any thread (hot path too).
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

namespace cobridge::canopen {

enum class DataType : std::uint16_t {
  kBoolean = 0x0001,
  kInteger8 = 0x0002,
  kInteger16 = 0x0003,
  kInteger32 = 0x0004,
  kUnsigned8 = 0x0005,
  kUnsigned16 = 0x0006,
  kUnsigned32 = 0x0007,
  kReal32 = 0x0008,
  kVisibleString = 0x0009,
  kOctetString = 0x000A,
  kUnicodeString = 0x000B,
  kTimeOfDay = 0x000C,
  kTimeDifference = 0x000D,
  kDomain = 0x000F,
  kInteger24 = 0x0010,
  kReal64 = 0x0011,
  kInteger40 = 0x0012,
  kInteger48 = 0x0013,
  kInteger56 = 0x0014,
  kInteger64 = 0x0015,
  kUnsigned24 = 0x0016,
  kUnsigned40 = 0x0018,
  kUnsigned48 = 0x0019,
  kUnsigned56 = 0x001A,
  kUnsigned64 = 0x001B,
};

// Size of a value of `type` on the bus, in bits; 0 for the variable-length
// types (strings, domain) and for values outside the enum.
[[nodiscard]] constexpr std::uint32_t bit_size(DataType type) noexcept {
  switch (type) {
    case DataType::kBoolean: return 1;
    case DataType::kInteger8: case DataType::kUnsigned8: return 8;
    case DataType::kInteger16: case DataType::kUnsigned16: return 16;
    case DataType::kInteger24: case DataType::kUnsigned24: return 24;
    case DataType::kInteger32: case DataType::kUnsigned32: case DataType::kReal32: return 32;
    case DataType::kInteger40: case DataType::kUnsigned40: return 40;
    case DataType::kInteger48: case DataType::kUnsigned48: return 48;
    case DataType::kTimeOfDay: case DataType::kTimeDifference: return 48;
    case DataType::kInteger56: case DataType::kUnsigned56: return 56;
    case DataType::kInteger64: case DataType::kUnsigned64: case DataType::kReal64: return 64;
    case DataType::kVisibleString: case DataType::kOctetString: case DataType::kUnicodeString:
    case DataType::kDomain:
      return 0;
  }
  return 0;
}

[[nodiscard]] constexpr bool is_signed_integer(DataType type) noexcept {
  switch (type) {
    case DataType::kInteger8: case DataType::kInteger16: case DataType::kInteger24:
    case DataType::kInteger32: case DataType::kInteger40: case DataType::kInteger48:
    case DataType::kInteger56: case DataType::kInteger64:
      return true;
    default:
      return false;
  }
}

// BOOLEAN counts as unsigned: it travels as one byte holding 0 or 1.
[[nodiscard]] constexpr bool is_unsigned_integer(DataType type) noexcept {
  switch (type) {
    case DataType::kBoolean: case DataType::kUnsigned8: case DataType::kUnsigned16:
    case DataType::kUnsigned24: case DataType::kUnsigned32: case DataType::kUnsigned40:
    case DataType::kUnsigned48: case DataType::kUnsigned56: case DataType::kUnsigned64:
      return true;
    default:
      return false;
  }
}

[[nodiscard]] constexpr bool is_real(DataType type) noexcept {
  return type == DataType::kReal32 || type == DataType::kReal64;
}

// The CiA 301 name ("UNSIGNED32"); "?" for values outside the enum.
[[nodiscard]] constexpr std::string_view to_string(DataType type) noexcept {
  switch (type) {
    case DataType::kBoolean: return "BOOLEAN";
    case DataType::kInteger8: return "INTEGER8";
    case DataType::kInteger16: return "INTEGER16";
    case DataType::kInteger32: return "INTEGER32";
    case DataType::kUnsigned8: return "UNSIGNED8";
    case DataType::kUnsigned16: return "UNSIGNED16";
    case DataType::kUnsigned32: return "UNSIGNED32";
    case DataType::kReal32: return "REAL32";
    case DataType::kVisibleString: return "VISIBLE_STRING";
    case DataType::kOctetString: return "OCTET_STRING";
    case DataType::kUnicodeString: return "UNICODE_STRING";
    case DataType::kTimeOfDay: return "TIME_OF_DAY";
    case DataType::kTimeDifference: return "TIME_DIFFERENCE";
    case DataType::kDomain: return "DOMAIN";
    case DataType::kInteger24: return "INTEGER24";
    case DataType::kReal64: return "REAL64";
    case DataType::kInteger40: return "INTEGER40";
    case DataType::kInteger48: return "INTEGER48";
    case DataType::kInteger56: return "INTEGER56";
    case DataType::kInteger64: return "INTEGER64";
    case DataType::kUnsigned24: return "UNSIGNED24";
    case DataType::kUnsigned40: return "UNSIGNED40";
    case DataType::kUnsigned48: return "UNSIGNED48";
    case DataType::kUnsigned56: return "UNSIGNED56";
    case DataType::kUnsigned64: return "UNSIGNED64";
  }
  return "?";
}

// The data type with type index `code`, or nullopt for reserved and
// out-of-range codes (a file's DataType= value is checked through this).
[[nodiscard]] constexpr std::optional<DataType> data_type_from_code(std::uint64_t code) noexcept {
  if (code == 0 || code > 0x001B || code == 0x000E || code == 0x0017) return std::nullopt;
  return static_cast<DataType>(code);
}

}  // namespace cobridge::canopen
