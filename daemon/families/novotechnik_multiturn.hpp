// Novotechnik multiturn sensors MZ1-2200, MC1-2800, MB1-3600 (manual E):
// identity, models and quirks.
//
// Quirks: since firmware V03 every model reports product 0x0BB8, before it
// each had its own code, and both are in the field (E§13 V03); scaling on =
// 0x6000 bit 2 CLEAR as E§5.3 prints it; the default TPDO1 mapping names
// 0x6020/1 although the position object is 0x6004 (E§4.1, E§4.2);
// node-ID and bit rate stored with 0x1010/4, communication with /2 (E§11).
// EMCY (E§9.1): byte 2 (0/1/2) and byte 3 form a sub-code, not the CiA error
// register, and every row has a level Info/Warn/Error/Hard that 0x2104
// filters; the position reads a sentinel during some errors.
//
// Thread contract: constants; any thread.
#pragma once

#include <cstdint>

#include "families/family.hpp"
#include "families/traits.hpp"

namespace cobridge::families {

// E§4.1: the product code of every model since V03.
inline constexpr std::uint32_t kMultiturnProduct = 0x0BB8;
// E§13: the codes before V03.
inline constexpr std::uint32_t kMz12200V02Product = 0x0BD5;
inline constexpr std::uint32_t kMc12800V02Product = 0x0BB9;
inline constexpr std::uint32_t kMb13600V02Product = 0x0BBC;

extern const Family kNovotechnikMultiturn;

// E§9.1: the measuring-range code (position valid / out of range (+) / (-)).
inline constexpr std::uint16_t kMultiturnMeasurementEmcy = 0x5051;
// E§9.1: what the position reads while a row's error is active.
inline constexpr std::int32_t kMultiturnErrorPosition = 0x7FFFFFFC;      // measurement/unknown/HW/ASIC/SW
inline constexpr std::int32_t kMultiturnOverflowPosition = 0x7FFFFFF8;   // out of range (+)
inline constexpr std::int32_t kMultiturnUnderflowPosition = -2147483640;  // 0x80000008, out of range (-)

// E§9.1 0x9080: byte 4 the changed CAMs 1-4, byte 7 the CAM state bits.
[[nodiscard]] EmcyDetailBytes multiturn_cam_emcy_bytes(std::uint8_t changed, std::uint8_t state) noexcept;
// E§9.1 0x9090: byte 7 the work-area state.
[[nodiscard]] EmcyDetailBytes multiturn_work_area_emcy_bytes(std::uint8_t state) noexcept;

// What the multiturn series does where the families differ (traits.hpp).
inline constexpr FamilyTraits kNovotechnikMultiturnTraits{
    .id = FamilyId::novotechnik_multiturn,
    .channel_count_in_eds = false,
    .position = {0x6004, false},                            // E§4.2
    .preset = {0x6003, false},                              // E§4.2
    .preset_signed = false,                                 // E§4.2 UNSIGNED32
    .position_alias = ChannelObject{0x6020, true},          // E§4.1 0x1A00/1 default
    .hardware_version = "V 1.00",                           // E§4.1 prints only an example
    .software_version = "V 1.03",
    .position_wraps = false,                                // E§9.1 overflow / underflow
    .range_monitoring = true,                               // E§9.1 0x5051
    .error_position = kMultiturnErrorPosition,              // E§9.1
    .limit_switch_flags = false,
    .speed_switchable = false,
    .speed_unit = SpeedUnit::deci_degree_per_s,             // E§3.4
    .work_area_range = WorkAreaRange::cia406_limits,        // E§4.2 0x650A
    .condition_monitoring = true,                           // E§4.3, E§5.8
    .store_subs = 4,                                        // E§11
    .kill_signature = true,                                 // E§11
    .load = LoadAction::revert_to_stored,                   // E§11
    .address_activation = AddressActivation::last_written,  // E§4.3
    .max_mapped_objects = 5,                                // E§8.2
    .mapping_needs_pre_operational = true,                  // E§8.2 step 1
    .tpdo_type0_off = true,                                 // E§4.1 0x1800/2
    .tpdo_async_every_cycle = true,                         // E§4.1 0x1800/2
    .rtr_transmission = false,
    .tpdo2_sync_only = true,                                // E§4.1 0x1801/2
    .tpdo2_needs_variant = false,
    .lss_bit_timings = 0x005F,                              // E§6.2: 1000, 800, 500, 250, 125, 50
};

}  // namespace cobridge::families
