// Numbers and byte strings as people type them into the control socket, the
// CiA 309-3 gateway and the state file: decimal, or hexadecimal with "0x"
// (signed ones with a leading '-'); no octal: a leading 0 is decimal;
// octet strings as pairs of hex digits. One parser for all of them, so the
// same text means the same number wherever it is typed; and one printer for
// what the daemon writes back (logs, errors, status, the state file):
// "0x" and upper-case digits, byte strings as pairs, objects as "0x1017/2".
//
// Thread: pure functions, any thread (not used on the hot path).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace cobridge {

// The whole `text` as an unsigned number no greater than `max`: decimal (or
// hexadecimal when `hex`), or hexadecimal with a 0x/0X prefix. False on
// anything else (empty, a sign, trailing characters, overflow).
[[nodiscard]] bool parse_unsigned(std::string_view text, std::uint64_t max, std::uint64_t& out,
                                  bool hex = false) noexcept;

// The whole `text` as a signed number within [min, max] (min <= 0 <= max):
// an optional '-', then decimal or 0x/0X-hexadecimal digits. The digits are
// the number's magnitude, never a bit pattern: "0xFFFF" is 65535, not -1, so
// it fits [-32768, 32767] only as "-1" or "-0x1". False on anything else
// (empty, '+', no digits, trailing characters, outside [min, max]).
[[nodiscard]] bool parse_signed(std::string_view text, std::int64_t min, std::int64_t max, std::int64_t& out) noexcept;

// Pairs of hex digits ("0A1b") appended to `out` as bytes; false (and `out`
// partly filled) when the text is empty, odd, longer than `max_bytes` bytes
// or not hex.
[[nodiscard]] bool parse_hex_bytes(std::string_view text, std::size_t max_bytes, std::vector<std::uint8_t>& out);

// "0x" and `v` in upper-case hex digits, zero-padded to `digits` (0: as
// many as the value needs): hex(0x1A, 4) is "0x001A", hex(0x1A) "0x1A".
[[nodiscard]] std::string hex(std::uint64_t v, int digits = 0);

// Bytes as pairs of upper-case hex digits, no separator ("0A1B"): the form
// parse_hex_bytes reads.
[[nodiscard]] std::string hex_bytes(std::span<const std::uint8_t> data);

// An object of a CANopen dictionary as the daemon's messages name it:
// "0x1017" (sub-index 0) or "0x1A00/2".
[[nodiscard]] std::string object_text(std::uint16_t index, std::uint8_t sub);

}  // namespace cobridge
