// ifm RM8xxx / RM9xxx encoders (manual F): identity, models and quirks.
//
// Quirks: the node-ID object 0x3000 holds node-ID - 1 ("always add 1") and
// the bit rate 0x3001 is an ascending table index (F§7.4); 0x1010 has sub 1
// only (F§7.3); "save with reset" is 0x2300 written with 0x55AAAA55
// (F§6.3.4); the product code is printed ambiguously ("0x43 0x41", F§7.3),
// so devices are selected by vendor alone; factory node-ID 32 (F§5.3.1) at
// 125 kbit/s (F§5.3.2). EMCY: one object (0x1014 writable, F§7.3) but no
// code table (F§4), so only the CiA 301 texts apply (Family::emcy is nullptr).
//
// Thread contract: constants; any thread.
#pragma once

#include <array>
#include <cstdint>

#include "families/family.hpp"

namespace cobridge::device::families {

inline constexpr std::uint32_t kIfmVendor = 0x0069666D;  // "ifm", F§7.3 0x1018/1
// F§7.3 prints 0x1018/2 as "0x43 0x41"; read like 'save' (high byte first) it
// is 0x00004341, the value the EDS and the simulator use.
inline constexpr std::uint32_t kIfmPrintedProduct = 0x00004341;
// F§7.4 0x3001: index 0..7, ascending (unlike the CiA 305 LSS table).
inline constexpr std::array<std::uint16_t, 8> kIfmBitRates{20, 50, 100, 125, 250, 500, 800, 1000};
// F§6.3.4 / F§7.4: "save parameters with reset".
inline constexpr std::uint16_t kIfmSaveWithResetObject = 0x2300;
inline constexpr std::uint32_t kIfmSaveWithResetCode = 0x55AAAA55;

extern const Family kIfmRm;

}  // namespace cobridge::device::families
