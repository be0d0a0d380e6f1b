// Novotechnik, the maker of two families (rotary, manual J; multiturn,
// manual E): what the two share.
//
// Thread contract: constants; any thread.
#pragma once

#include <array>
#include <cstdint>

namespace cobridge::device::families {

inline constexpr std::uint32_t kNovotechnikVendor = 0x00000182;  // J§1.2.1, E§4.1 0x1018/1
// Bit rates of the ordering codes (J§1.2.2, E§3.1), written in kbit/s to
// 0x2001 (J§1.3.3, E§4.3).
inline constexpr std::array<std::uint16_t, 6> kNovotechnikBitRates{50, 125, 250, 500, 800, 1000};
// Factory node-ID (J§1.2.2, E§3.1); 250 kbit/s (ordering code _4) is cobridge-sim's choice.
inline constexpr std::uint8_t kNovotechnikFactoryNodeId = 127;

}  // namespace cobridge::device::families
