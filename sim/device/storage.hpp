// Storage coverage: which objects each 0x1010 'save' / 0x1011 'load' / 'kill'
// sub-index covers, per family, and the signatures.
//
// Novotechnik rotary: the J§1.10 table (RSX-7900 /
// RFX-6900 differ: node-ID and bit rate under /1, CAM hysteresis and work
// area under /3 only, /4 = manufacturer data). Multiturn: E§11 table
// ifm: the F§6.3.1 list, sub 1 only (F§7.3 0x1010), plus the
// work-area limits 0x6401/0x6402 because F links them to the stored
// 0x2104/0x2105.
// "D" in the Novotechnik tables (TPDO COB-ID under /1) means the sub-index
// stores / loads the default, not the current value.
// Thread: pure functions.
#pragma once

#include <cstdint>

#include "families/family.hpp"
#include "families/ifm_rm.hpp"
#include "device/sim_device.hpp"

namespace cobridge::sim {

inline constexpr std::uint32_t kSignatureSave = families::kSaveSignature;  // "save"
inline constexpr std::uint32_t kSignatureLoad = 0x64616F6C;  // "load"
inline constexpr std::uint32_t kSignatureKill = 0x6C6C696B;  // "kill" (J§1.10 V11, E§11)
inline constexpr std::uint32_t kIfmSaveWithReset = families::kIfmSaveWithResetCode;  // F§6.3.4, 0x2300

enum class Coverage : std::uint8_t { none, value, default_value };

[[nodiscard]] Coverage store_coverage(FamilyId family, bool legacy_rsx_rfx, std::uint8_t store_sub,
                                      std::uint16_t index, std::uint8_t sub) noexcept;

// Highest 0x1010 / 0x1011 sub-index that takes a signature on this device
// (sub 5 'save' is accepted by Novotechnik but stores nothing a user sets).
[[nodiscard]] std::uint8_t store_sub_count(FamilyId family) noexcept;

}  // namespace cobridge::sim
