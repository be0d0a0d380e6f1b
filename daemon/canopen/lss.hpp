// LSS (CiA 305 Layer Setting Services): the wire vocabulary that the LSS
// master and the LSS slave share.
//
// LSS sets node-ID and bit rate of a device that is addressed by its 128-bit
// identity (0x1018/1..4) instead of by a node-ID, which is how devices that all
// ship at node-ID 127 (J§1.2.2, E§3.1) are told apart. Every LSS frame is 8
// bytes; byte 0 is the command specifier, multi-byte values are little-endian
// in bytes 1..4 (J§1.5, E§6). The manuals document only 0x04, 0x40..0x44,
// 0x11, 0x13 and 0x17; the other specifiers come from CiA 305 itself.
// Thread-safety: constants and pure functions only; callable from any thread.
#pragma once

#include <compare>
#include <cstdint>

#include "can/frame.hpp"
#include "canopen/cob_id.hpp"

namespace cobridge::canopen {

// Command specifiers (byte 0). Values are the CiA 305 wire codes.
enum class LssCs : uint8_t {
  kSwitchStateGlobal = 0x04,
  kConfigureNodeId = 0x11,
  kConfigureBitTiming = 0x13,
  kActivateBitTiming = 0x15,
  kStoreConfiguration = 0x17,
  kSwitchSelectiveVendor = 0x40,
  kSwitchSelectiveProduct = 0x41,
  kSwitchSelectiveRevision = 0x42,
  kSwitchSelectiveSerial = 0x43,
  kSwitchSelectiveResponse = 0x44,
  kIdentifyVendor = 0x46,
  kIdentifyProduct = 0x47,
  kIdentifyRevisionLow = 0x48,
  kIdentifyRevisionHigh = 0x49,
  kIdentifySerialLow = 0x4A,
  kIdentifySerialHigh = 0x4B,
  kIdentifyNonConfigured = 0x4C,
  kIdentifySlave = 0x4F,               // answer to identify remote slave and Fastscan
  kIdentifyNonConfiguredSlave = 0x50,  // answer to 0x4C
  kFastscan = 0x51,
  kInquireVendor = 0x5A,
  kInquireProduct = 0x5B,
  kInquireRevision = 0x5C,
  kInquireSerial = 0x5D,
  kInquireNodeId = 0x5E,
};

// LSS state; the value is byte 1 of switch state global (J§1.5: 00 waiting,
// 01 configuration).
enum class LssMode : uint8_t { kWaiting = 0, kConfiguration = 1 };

// The four identity fields in the order Fastscan walks them (LSSSub values).
enum class LssField : uint8_t { kVendor = 0, kProduct = 1, kRevision = 2, kSerial = 3 };
inline constexpr uint8_t kLssFieldCount = 4;

// Fastscan BitChecked value that resets every unconfigured slave's field
// pointer and asks "is any unconfigured slave there?".
inline constexpr uint8_t kLssFastscanReset = 0x80;

// The LSS address: 0x1018 sub 1..4. Ordered lexicographically in field order,
// which is the order in which Fastscan finds devices (smallest first).
struct LssAddress {
  uint32_t vendor = 0;
  uint32_t product = 0;
  uint32_t revision = 0;
  uint32_t serial = 0;

  [[nodiscard]] constexpr uint32_t field(LssField f) const noexcept {
    switch (f) {
      case LssField::kVendor: return vendor;
      case LssField::kProduct: return product;
      case LssField::kRevision: return revision;
      case LssField::kSerial: return serial;
    }
    return 0;
  }
  constexpr void set_field(LssField f, uint32_t v) noexcept {
    switch (f) {
      case LssField::kVendor: vendor = v; break;
      case LssField::kProduct: product = v; break;
      case LssField::kRevision: revision = v; break;
      case LssField::kSerial: serial = v; break;
    }
  }
  friend constexpr auto operator<=>(const LssAddress&, const LssAddress&) = default;
};

// Identify remote slave selection: exact vendor and product, inclusive
// revision and serial ranges.
struct LssRange {
  uint32_t vendor = 0;
  uint32_t product = 0;
  uint32_t rev_lo = 0;
  uint32_t rev_hi = 0xFFFFFFFFu;
  uint32_t serial_lo = 0;
  uint32_t serial_hi = 0xFFFFFFFFu;

  [[nodiscard]] constexpr bool contains(const LssAddress& a) const noexcept {
    return a.vendor == vendor && a.product == product && a.revision >= rev_lo &&
           a.revision <= rev_hi && a.serial >= serial_lo && a.serial <= serial_hi;
  }
};

// Standard CiA bit-timing table (table selector 0). J§1.5.2 and E§6.2 list
// 0, 1, 2, 3, 4 and 6; 5 is reserved, 7 and 8 exist in CiA 305 but the
// Novotechnik devices answer "not supported" for them (J§1.5.2 error 1).
inline constexpr uint8_t kLssBitTimingTableStandard = 0;
enum class LssBitTiming : uint8_t {
  k1000 = 0,
  k800 = 1,
  k500 = 2,
  k250 = 3,
  k125 = 4,
  kReserved = 5,
  k50 = 6,
  k20 = 7,
  k10 = 8,
  kAuto = 9,
};

// kbit/s of a standard-table index; 0 for reserved, automatic and unknown.
[[nodiscard]] constexpr uint16_t lss_bit_rate_kbit(uint8_t index) noexcept {
  switch (static_cast<LssBitTiming>(index)) {
    case LssBitTiming::k1000: return 1000;
    case LssBitTiming::k800: return 800;
    case LssBitTiming::k500: return 500;
    case LssBitTiming::k250: return 250;
    case LssBitTiming::k125: return 125;
    case LssBitTiming::k50: return 50;
    case LssBitTiming::k20: return 20;
    case LssBitTiming::k10: return 10;
    case LssBitTiming::kReserved:
    case LssBitTiming::kAuto: return 0;
  }
  return 0;
}

// Bit i set = standard-table index i supported. The Novotechnik set (J§1.5.2,
// E§6.2): 1000, 800, 500, 250, 125, 50 kbit/s.
inline constexpr uint16_t kLssBitTimingsNovotechnik = 0x005F;

// Error codes in byte 1 of the configure/store answers (J§1.5.1-1.5.3,
// E§6.1-6.3, CiA 305). 0xFF means "see byte 2, manufacturer-specific".
enum class LssNodeIdError : uint8_t { kOk = 0, kOutOfRange = 1, kSpecific = 0xFF };
enum class LssBitTimingError : uint8_t { kOk = 0, kNotSupported = 1, kSpecific = 0xFF };
enum class LssStoreError : uint8_t { kOk = 0, kNotSupported = 1, kMediaAccess = 2, kSpecific = 0xFF };

// Node-IDs configure node-ID accepts: 1..127, and FFh (back to "unconfigured",
// CiA 305 V3). 0 and 128..254 are "out of range".
[[nodiscard]] constexpr bool lss_node_id_acceptable(uint8_t id) noexcept {
  return cob::valid_node_id(id) || id == cob::kNodeIdUnconfigured;
}

// An 8-byte LSS frame: cs, a 32-bit value in bytes 1..4, then bytes 5..7.
[[nodiscard]] constexpr can::Frame lss_frame(uint32_t cob_id, uint8_t cs, uint32_t value = 0,
                                             uint8_t b5 = 0, uint8_t b6 = 0,
                                             uint8_t b7 = 0) noexcept {
  return can::Frame::make8(cob_id, {cs, static_cast<uint8_t>(value), static_cast<uint8_t>(value >> 8),
                                    static_cast<uint8_t>(value >> 16), static_cast<uint8_t>(value >> 24),
                                    b5, b6, b7});
}

// Bytes 1..4 of an LSS frame as a little-endian 32-bit value.
[[nodiscard]] constexpr uint32_t lss_value(const can::Frame& f) noexcept {
  return static_cast<uint32_t>(f.data[1]) | (static_cast<uint32_t>(f.data[2]) << 8) |
         (static_cast<uint32_t>(f.data[3]) << 16) | (static_cast<uint32_t>(f.data[4]) << 24);
}

// True for a well-formed LSS frame on `cob_id`: 11-bit data frame, 8 bytes.
[[nodiscard]] constexpr bool is_lss_frame(const can::Frame& f, uint32_t cob_id) noexcept {
  return f.id == cob_id && f.len == 8 && !f.is_rtr() && !f.is_extended() && !f.is_error();
}

}  // namespace cobridge::canopen
