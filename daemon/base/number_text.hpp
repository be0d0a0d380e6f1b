// Numbers and byte strings as people type them into the control socket, the
// CiA 309-3 gateway and the state file: decimal, or hexadecimal with "0x"
// (signed ones with a leading '-'); no octal: a leading 0 is decimal;
// octet strings as pairs of hex digits. One parser for all of them, so the
// same text means the same number wherever it is typed.
//
// Thread: pure functions, any thread (not used on the hot path).
#pragma once

#include <cstddef>
#include <cstdint>
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

}  // namespace cobridge
