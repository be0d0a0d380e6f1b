// Numbers as people type them on cobridge-sim's command line and control
// channel: decimal, or hexadecimal with a 0x prefix; signed decimals for
// offsets. Whole-string parses only ("12ab" is not 12).
// Thread: any; pure functions.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

namespace cobridge::sim {

// Decimal or 0x-prefixed hexadecimal, at most `max`.
[[nodiscard]] std::optional<std::uint64_t> parse_unsigned(std::string_view text,
                                                          std::uint64_t max = UINT64_MAX) noexcept;
// A hexadecimal number with or without 0x (COB-IDs on the control channel).
[[nodiscard]] std::optional<std::uint32_t> parse_hex32(std::string_view text) noexcept;
// A decimal real number such as "-1.25" or "3" (turns).
[[nodiscard]] std::optional<double> parse_real(std::string_view text) noexcept;

}  // namespace cobridge::sim
