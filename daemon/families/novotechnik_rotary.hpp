// Novotechnik rotary sensors RFC-4800, RSA-3200, RFE-3200, RSX-7900,
// RFX-6900 (manual J): identity, models and quirks.
//
// Quirks: LSS per DSP-305 V1.1.2 (J§1 intro), older than Fastscan; node-ID
// and bit rate stored with 0x1010/4, except RSX-7900 / RFX-6900 firmware
// which stores them with /1 (J§1.6.1, J§1.12 V10); communication parameters
// with /2 because /1 resets the TPDO COB-IDs (J§1.10); scaling on = 0x6000
// bit 2 set (J§1.4.1); moving average in 0x6000 bits 14..12 (J§1.4.1).
// EMCY (J§1.8.1): byte 2 is the CiA error register (1 while an error is
// active); 0x8110 tells overrun from buffer overflow in bytes 3-4; the CAM and
// work-area frames carry the channel in bytes 3-4, the CAMs in bytes 5-6 and
// the new state in byte 7. The position reads 0x7FF0 during an error (J§1.8).
//
// Thread contract: constants; any thread.
#pragma once

#include <cstdint>

#include "families/family.hpp"
#include "families/traits.hpp"

namespace cobridge::families {

// J§1.2.1 product codes (0x1018/2).
inline constexpr std::uint32_t kRfc4800Product = 0x0BE0;
inline constexpr std::uint32_t kRsa3200Product = 0x0BF3;
inline constexpr std::uint32_t kRfe3200Product = 0x0BBD;
inline constexpr std::uint32_t kRsx7900Product = 0x0BCD;
inline constexpr std::uint32_t kRfx6900Product = 0x0BE1;

// J§1.6.1 / J§1.12 V10: RSX-7900 / RFX-6900 store the node-ID with 0x1010/1.
inline constexpr std::uint8_t kRotaryLegacyNodeIdStoreSub = 1;

extern const Family kNovotechnikRotary;

// J§1.8: the position value while a position or sensor error is active.
inline constexpr std::int32_t kRotaryErrorPosition = 0x7FF0;

// J§1.8.1 0x9080: bytes 3-4 channel, bytes 5-6 CAMs, byte 7 the new 0x6300 value.
[[nodiscard]] EmcyDetailBytes rotary_cam_emcy_bytes(std::uint16_t channel, std::uint16_t cams,
                                                    std::uint8_t state) noexcept;
// J§1.8.1 0x9090: bytes 3-4 channel, byte 7 the new 0x6400 value.
[[nodiscard]] EmcyDetailBytes rotary_work_area_emcy_bytes(std::uint16_t channel, std::uint8_t state) noexcept;

// J§1.12 V10: the product runs the RSX-7900 / RFX-6900 firmware rules.
[[nodiscard]] bool is_legacy_rsx_rfx(std::uint32_t product) noexcept;

// What the rotary series does where the families differ (traits.hpp).
inline constexpr FamilyTraits kNovotechnikRotaryTraits{
    .id = FamilyId::novotechnik_rotary,
    .channel_count_in_eds = true,                          // J§1.3.2 0x6020/0
    .position = {0x6020, true},                            // J§1.3.2
    .preset = {0x6010, true},                              // J§1.3.2
    .preset_signed = true,                                 // J§1.3.2 INTEGER32
    .position_alias = std::nullopt,
    .hardware_version = "V 1.00",                          // J§1.3.1 example
    .software_version = "V 1.03",                          // J§1.3.1 example
    .position_wraps = true,
    .range_monitoring = false,
    .error_position = kRotaryErrorPosition,                // J§1.8
    .limit_switch_flags = false,
    .speed_switchable = false,
    .speed_unit = SpeedUnit::deci_degree_per_s,            // J gives no unit; E§3.4's assumed
    .work_area_range = WorkAreaRange::preset_to_length,    // J§1.4.6.1
    .condition_monitoring = false,
    .store_subs = 4,                                       // J§1.10
    .kill_signature = true,                                // J§1.10
    .load = LoadAction::revert_to_stored,                  // J§1.10
    .address_activation = AddressActivation::last_written, // J§1.3.3
    .max_mapped_objects = 5,                               // J§1.7.2
    .mapping_needs_pre_operational = false,                // J§1.7.2 asks for the PDO disabled only
    .tpdo_type0_off = true,                                // J§1.3.1 0x1800/2
    .tpdo_async_every_cycle = true,                        // J§1.3.1 0x1800/2
    .rtr_transmission = false,
    .tpdo2_sync_only = true,                               // J§1.3.1 0x1801/2
    .tpdo2_needs_variant = false,
    .lss_bit_timings = 0x005F,                             // J§1.5.2: 1000, 800, 500, 250, 125, 50
};

}  // namespace cobridge::families
