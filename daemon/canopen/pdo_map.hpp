// PdoLayout: where each mapped object sits in a PDO, built from the mapping
// entries of 0x1600/0x1A00 sub 1..n (CiA 301 §7.4.8, `index<<16 | sub<<8 |
// length in bits`), and the decoding / encoding of PDO payloads with it.
//
// Building a layout validates the mapping and happens off the hot path (when
// the gateway has read 0x1A0x back, or when the simulator's mapping is
// written); errors carry a std::error_code of `pdo_map_category()` and a
// message. Decoding and encoding run on the hot path (the gateway's RX
// thread, the simulator's TX path): noexcept, no allocation, no exceptions.
//
// Lengths: the CiA 301 payload limit is 64 bits; values are decoded up to 32
// bits each, at any bit offset, little-endian (CiA 301 §7.1: bit 0 of the
// first mapped object is bit 0 of byte 0). The Novotechnik devices add a
// limit of 5 entries per PDO (J§1.7.2, E§8.2), which PdoLimits carries.
//
// Frame length policy (CiA 301 §7.2.2.3): a frame shorter than the layout is
// a PDO length error (EMCY 0x8210) and is rejected. A longer frame is
// accepted and decoded from its first bytes, but the result says so, so the
// caller can count it (CiA 301's EMCY 0x8220 "PDO length exceeded" is
// optional). The three manuals say nothing on received PDOs: their devices
// only transmit (J§1.8, E§9 "sensor supports TPDOs only").
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <system_error>

#include "can/frame.hpp"

namespace cobridge::canopen {

// One mapping entry, as stored in 0x1A00 sub 1..n.
struct PdoMapEntry {
  uint16_t index = 0;
  uint8_t sub = 0;
  uint8_t bits = 0;

  [[nodiscard]] static constexpr PdoMapEntry from_raw(uint32_t raw) noexcept {
    return {static_cast<uint16_t>(raw >> 16), static_cast<uint8_t>((raw >> 8) & 0xFF),
            static_cast<uint8_t>(raw & 0xFF)};
  }
  [[nodiscard]] constexpr uint32_t raw() const noexcept {
    return (uint32_t{index} << 16) | (uint32_t{sub} << 8) | bits;
  }
  // CiA 301 dummy mapping: indices 0x0001..0x0007 are the basic data types
  // and only reserve room (used by RPDOs to skip data).
  [[nodiscard]] constexpr bool is_dummy() const noexcept { return index >= 0x0001 && index <= 0x0007; }
};

[[nodiscard]] constexpr uint32_t make_mapping_entry(uint16_t index, uint8_t sub, uint8_t bits) noexcept {
  return PdoMapEntry{index, sub, bits}.raw();
}

// How a mapped value is read: its signedness. The caller knows the data
// type of each object (from the EDS or the device family); it says so
// through a PdoTypeLookup. Without a lookup every object is unsigned.
enum class PdoValueKind : uint8_t { unsigned_integer, signed_integer };
using PdoTypeLookup = std::function<PdoValueKind(uint16_t index, uint8_t sub)>;

struct PdoField {
  uint16_t index = 0;
  uint8_t sub = 0;
  uint8_t bit_offset = 0;
  uint8_t bit_length = 0;
  PdoValueKind kind = PdoValueKind::unsigned_integer;
  bool dummy = false;
};

struct PdoLimits {
  std::size_t max_entries = 64;  // CiA 301: 64 one-bit objects fill a PDO
  uint8_t max_bits = 64;
};
inline constexpr std::size_t kNovotechnikMaxPdoEntries = 5;  // J§1.7.2, E§8.2

// Validation errors; CiA 301 names the SDO abort a device returns for each.
enum class PdoMapErrc {
  too_many_entries = 1,  // more entries than the device maps (0x06040042)
  zero_length,           // an entry with length 0 (0x06040041)
  entry_too_long,        // longer than 32 bits: not decoded here (0x06040041)
  payload_too_long,      // total > 64 bits / 8 bytes (0x06040042)
};
[[nodiscard]] const std::error_category& pdo_map_category() noexcept;
[[nodiscard]] std::error_code make_error_code(PdoMapErrc e) noexcept;
// The CiA 301 SDO abort code a device answers a mapping write with.
[[nodiscard]] uint32_t sdo_abort_code(PdoMapErrc e) noexcept;

enum class PdoDecodeStatus : uint8_t {
  ok,
  ok_longer_frame,  // decoded from the first bytes; CiA 301 EMCY 0x8220 case
  too_short,        // not decoded; CiA 301 EMCY 0x8210 case
  remote_request,   // an RTR carries no data
  too_few_outputs,  // the output span is smaller than field_count()
};

class PdoLayout {
 public:
  static constexpr std::size_t kMaxFields = 64;

  [[nodiscard]] std::size_t field_count() const noexcept { return count_; }
  [[nodiscard]] const PdoField& field(std::size_t i) const noexcept { return fields_[i]; }
  [[nodiscard]] uint8_t total_bits() const noexcept { return total_bits_; }
  // Bytes a frame must carry: total bits rounded up.
  [[nodiscard]] uint8_t frame_length() const noexcept {
    return static_cast<uint8_t>((total_bits_ + 7U) / 8U);
  }

  // Decodes every field into `out[i]` (sign-extended for signed fields).
  // Dummy fields decode as their raw bits.
  PdoDecodeStatus decode(const can::Frame& frame, std::span<int64_t> out) const noexcept;
  // Reads field `i` from `data` without a length check; for callers that
  // checked frame_length() themselves.
  [[nodiscard]] int64_t value(std::span<const uint8_t, 8> data, std::size_t i) const noexcept;

  // Writes `values` into `frame` (data and len = frame_length(); id, flags
  // untouched). Values are cut to their field width in two's complement, as
  // a device writing an INTEGER16 would. Returns false if `values` is short.
  bool encode(std::span<const int64_t> values, can::Frame& frame) const noexcept;

 private:
  friend struct PdoLayoutBuilder;
  std::array<PdoField, kMaxFields> fields_{};
  uint8_t count_ = 0;
  uint8_t total_bits_ = 0;
};

struct PdoLayoutResult {
  std::error_code error;
  std::string message;  // which entry and why; empty on success
  PdoLayout layout;
  [[nodiscard]] bool ok() const noexcept { return !error; }
};

// `entries` are sub 1..n in order (n = sub 0). Off the hot path.
[[nodiscard]] PdoLayoutResult build_pdo_layout(std::span<const uint32_t> entries,
                                               const PdoTypeLookup& lookup = {},
                                               const PdoLimits& limits = {});

}  // namespace cobridge::canopen

template <>
struct std::is_error_code_enum<cobridge::canopen::PdoMapErrc> : std::true_type {};
