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
#include "families/traits.hpp"

namespace cobridge::families {

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

// What the ifm RM series does where the families differ (traits.hpp).
inline constexpr FamilyTraits kIfmRmTraits{
    .id = FamilyId::ifm_rm,
    .channel_count_in_eds = false,
    .position = {0x6004, false},                          // F§7.5
    .preset = {0x6003, false},                            // F§7.5
    .preset_signed = false,                               // F§7.5 UNSIGNED32
    .position_alias = std::nullopt,
    .hardware_version = "1.0",                            // F§7.3 prints "x.x"
    .software_version = "1.0",                            // F§7.3 prints "x.x"
    .position_wraps = true,
    .range_monitoring = false,
    .error_position = std::nullopt,                       // F documents no error value
    .limit_switch_flags = true,                           // F§7.4 0x2104/0x2105
    .speed_switchable = true,                             // F§7.4 0x3010
    .speed_unit = SpeedUnit::digits_per_s,                // F§7.4 0x3011
    .work_area_range = WorkAreaRange::cia406_limits,      // F§7.5 0x650A
    .condition_monitoring = false,
    .store_subs = 1,                                      // F§7.3 0x1010
    .kill_signature = false,                              // F§6.3.3-F§6.3.5: save and load only
    .load = LoadAction::factory_after_reset,              // F§6.3.5
    .address_activation = AddressActivation::stored_first,  // F§7.4 0x3000/0x3001
    .max_mapped_objects = 2,                              // F§7.3 0x1A00 sub-indices 1..2
    .mapping_needs_pre_operational = false,
    .tpdo_type0_off = false,                              // F§7.3: 0 = acyclic synchronous
    .tpdo_async_every_cycle = false,                      // F§7.3: on change, event timer
    .rtr_transmission = true,                             // F§7.3 types 252/253
    .tpdo2_sync_only = false,                             // F§7.3 0x1801 has the full record
    .tpdo2_needs_variant = true,                          // F§7.3: TPDO2 on the C6 variant
    .lss_bit_timings = 0x00DF,                            // F§7.4 less 100 kbit/s: 1000 .. 20
};

}  // namespace cobridge::families
