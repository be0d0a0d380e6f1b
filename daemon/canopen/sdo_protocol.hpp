// SDO frame layout (CiA 301 §7.2.4.3): the command byte's specifiers and
// flag bits, and the little-endian fields of the 8-byte SDO frame. Private to
// the canopen layer: shared by the SDO client and the SDO server so the two
// sides of the protocol read and write the same layout.
//
// Thread: constexpr/noexcept helpers, called from whichever thread drives the
// client or server (the hot path included); they never allocate.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace cobridge::canopen::sdo_protocol {

// Byte 0 (CiA 301 §7.2.4.3.3..§7.2.4.3.7, §7.2.4.3.17): bits 7..5 are the
// command specifier, the other bits depend on it.
inline constexpr std::uint8_t kCsShift = 5;

// Client command specifiers (requests).
inline constexpr std::uint8_t kCcsDownloadSegment = 0;
inline constexpr std::uint8_t kCcsDownloadInitiate = 1;
inline constexpr std::uint8_t kCcsUploadInitiate = 2;
inline constexpr std::uint8_t kCcsUploadSegment = 3;
// Server command specifiers (responses).
inline constexpr std::uint8_t kScsUploadSegment = 0;
inline constexpr std::uint8_t kScsDownloadSegment = 1;
inline constexpr std::uint8_t kScsUploadInitiate = 2;
inline constexpr std::uint8_t kScsDownloadInitiate = 3;
// Abort transfer: the same specifier in both directions.
inline constexpr std::uint8_t kCsAbort = 4;
// Block download (§7.2.4.3.9..§7.2.4.3.14): the client's ccs and the
// server's scs; the low bits say which step (initiate, end, block ack).
inline constexpr std::uint8_t kCcsBlockDownload = 6;
inline constexpr std::uint8_t kScsBlockDownload = 5;

inline constexpr std::uint8_t kBitToggle = 0x10;         // segment frames: t
inline constexpr std::uint8_t kBitExpedited = 0x02;      // initiate frames: e
inline constexpr std::uint8_t kBitSizeIndicated = 0x01;  // initiate frames: s
inline constexpr std::uint8_t kBitLastSegment = 0x01;    // segment frames: c

// Payload bytes of an expedited transfer (d[4..7]) and of one segment (d[1..7]).
inline constexpr std::size_t kExpeditedMax = 4;
inline constexpr std::size_t kSegmentMax = 7;

// Byte 0 with command specifier `cs` and no flag bits set.
[[nodiscard]] constexpr std::uint8_t command(std::uint8_t cs) noexcept {
  return static_cast<std::uint8_t>(cs << kCsShift);
}

// The command specifier of byte 0.
[[nodiscard]] constexpr std::uint8_t specifier(std::uint8_t byte0) noexcept {
  return static_cast<std::uint8_t>(byte0 >> kCsShift);
}

// Initiate and abort frames carry the multiplexer in bytes 1..3: index
// (little-endian) and sub-index.
[[nodiscard]] constexpr std::uint16_t index_of(const std::array<std::uint8_t, 8>& d) noexcept {
  return static_cast<std::uint16_t>(d[1] | (d[2] << 8U));
}

// An initiate or abort frame's bytes: `byte0`, the multiplexer, four zero
// data bytes.
[[nodiscard]] constexpr std::array<std::uint8_t, 8> multiplexed(std::uint8_t byte0, std::uint16_t index,
                                                                std::uint8_t sub) noexcept {
  return {byte0, static_cast<std::uint8_t>(index & 0xFFU), static_cast<std::uint8_t>(index >> 8U), sub, 0, 0, 0, 0};
}

// Sizes and abort codes travel as UNSIGNED32, little-endian (CiA 301 §7.1).
[[nodiscard]] constexpr std::uint32_t read_u32le(const std::array<std::uint8_t, 8>& d, std::size_t at) noexcept {
  return static_cast<std::uint32_t>(d[at]) | (static_cast<std::uint32_t>(d[at + 1]) << 8U) |
         (static_cast<std::uint32_t>(d[at + 2]) << 16U) | (static_cast<std::uint32_t>(d[at + 3]) << 24U);
}

constexpr void write_u32le(std::array<std::uint8_t, 8>& d, std::size_t at, std::uint32_t v) noexcept {
  for (std::size_t i = 0; i < 4; ++i) d[at + i] = static_cast<std::uint8_t>((v >> (8U * i)) & 0xFFU);
}

}  // namespace cobridge::canopen::sdo_protocol
