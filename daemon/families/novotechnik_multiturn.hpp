// Novotechnik multiturn sensors MZ1-2200, MC1-2800, MB1-3600 (manual E):
// identity, models and quirks.
//
// Quirks: since firmware V03 every model reports product 0x0BB8, before it
// each had its own code, and both are in the field (E§13 V03); scaling on =
// 0x6000 bit 2 CLEAR as E§5.3 prints it; the default TPDO1 mapping names
// 0x6020/1 although the position object is 0x6004 (E§4.1, E§4.2);
// node-ID and bit rate stored with 0x1010/4, communication with /2 (E§11).
//
// Thread contract: constants; any thread.
#pragma once

#include <cstdint>

#include "families/family.hpp"

namespace cobridge::device::families {

// E§4.1: the product code of every model since V03.
inline constexpr std::uint32_t kMultiturnProduct = 0x0BB8;
// E§13: the codes before V03.
inline constexpr std::uint32_t kMz12200V02Product = 0x0BD5;
inline constexpr std::uint32_t kMc12800V02Product = 0x0BB9;
inline constexpr std::uint32_t kMb13600V02Product = 0x0BBC;

extern const Family kNovotechnikMultiturn;

}  // namespace cobridge::device::families
