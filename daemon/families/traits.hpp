// FamilyTraits: the behaviour of a family that code would otherwise branch on
// by FamilyId (which object carries the position, how 'load' acts, which
// TPDO types exist, ...), as values. Each family's header defines its own
// `constexpr FamilyTraits` next to its identity; family_traits.hpp gathers
// them in a table indexed by FamilyId. No member has a default: a family that
// leaves one out does not compile (-Wmissing-field-initializers, -Werror).
//
// Code that needs more than a value (a family's own write rules, EMCY frames,
// status bits) switches on FamilyId with no `default`, so that -Wswitch names
// every such switch when a family is added (docs/adding-a-device.md).
//
// Thread contract: constants; any thread.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "families/family.hpp"

namespace cobridge::families {

// An object that exists once per position channel (sub-index = channel, 1..2)
// or once per device (sub-index 0).
struct ChannelObject {
  std::uint16_t index;
  bool per_channel;
  [[nodiscard]] constexpr std::uint8_t sub(std::uint8_t channel) const noexcept {
    return per_channel ? channel : std::uint8_t{0};
  }
};

// The unit of the speed object 0x6030.
enum class SpeedUnit : std::uint8_t {
  deci_degree_per_s,  // 0.1 °/s (E§3.4; assumed for J, whose manual gives no unit)
  digits_per_s,       // steps per second (F§7.4 0x3011)
};

// What a 'load' signature written to 0x1011 does.
enum class LoadAction : std::uint8_t {
  revert_to_stored,            // RAM takes the last saved values at once (J§1.10, E§11)
  factory_after_reset,         // factory values, active at the next reset, EEPROM untouched (F§6.3.5)
};

// Which node-ID and bit rate a reset-node activates.
enum class AddressActivation : std::uint8_t {
  // The values last written (SDO 0x2000/0x2001 or LSS), stored or not (J§1.3.3, E§4.3).
  last_written,
  // The stored values when there are any, else the last written (F§7.4 0x3000/0x3001).
  stored_first,
};

// How the 0x6300 CAMs' range check and the 0x6400 work area find their bounds.
enum class WorkAreaRange : std::uint8_t {
  preset_to_length,   // J§1.4.6.1: bit 0 for position <= preset or >= sensor length
  cia406_limits,      // 0x650A/2..3 (E§4.2, F§7.5)
};

struct FamilyTraits {
  FamilyId id;

  // --- channels and objects ---
  // The EDS's 0x6020/0 default tells the channel count (J§1.3.2); otherwise 1.
  bool channel_count_in_eds;
  ChannelObject position;  // J§1.3.2 0x6020/ch; E§4.2, F§7.5 0x6004
  ChannelObject preset;    // J§1.3.2 0x6010/ch; E§4.2, F§7.5 0x6003
  bool preset_signed;      // INTEGER32 (J§1.3.2) or UNSIGNED32 (E§4.2, F§7.5)
  // A second object the default mapping names for the position (E§4.1 0x1A00/1 = 0x6020/1).
  std::optional<ChannelObject> position_alias;
  std::string_view hardware_version;  // 0x1009 as the simulator reports it
  std::string_view software_version;  // 0x100A as the simulator reports it

  // --- position ---
  // The position counts modulo the total range; false: it runs past the
  // range into the E§9.1 overflow / underflow states instead.
  bool position_wraps;
  // The measuring-range states of E§9.1 (info, warning, error over/under).
  bool range_monitoring;
  // What the position reads while a measurement error is active; nullopt:
  // the manual documents none and the last position is held (F).
  std::optional<std::int32_t> error_position;
  // Bits 30/31 flag the 0x2104/0x2105 limits and bits 29..0 carry the value (F§7.4).
  bool limit_switch_flags;
  // Speed is off until 0x3010/1 = 1, with its window in 0x3010/2 (F§7.4).
  bool speed_switchable;
  SpeedUnit speed_unit;
  WorkAreaRange work_area_range;
  // Temperature, supply voltage and operating time (E§4.3 0x2002..0x23xx, E§5.8).
  bool condition_monitoring;

  // --- storage ---
  std::uint8_t store_subs;  // 0x1010/0x1011 sub-indices 1..n (J§1.10, E§11: 4; F§7.3: 1)
  bool kill_signature;      // 0x1010 'kill' resets to factory values (J§1.10, E§11)
  LoadAction load;
  AddressActivation address_activation;

  // --- PDOs ---
  std::uint8_t max_mapped_objects;      // J§1.7.2, E§8.2: 5; F§7.3 0x1A00: sub-indices 1..2
  bool mapping_needs_pre_operational;  // E§8.2 step 1
  bool tpdo_type0_off;                 // type 0 disables the TPDO (J§1.3.1, E§4.1)
  // Types 254/255 send every measuring cycle (J§1.3.1, E§4.1); false: on a
  // change of the mapped values, at most every event time (F§7.3).
  bool tpdo_async_every_cycle;
  bool rtr_transmission;      // types 252/253 (F§7.3)
  bool tpdo2_sync_only;       // TPDO2 types 0..240 only (J§1.3.1, E§4.1 0x1801/2)
  bool tpdo2_needs_variant;   // TPDO2 only on the C6 variant (F§7.3)

  // --- LSS ---
  // CiA 305 bit-timing table indices the device accepts (J§1.5.2, E§6.2;
  // F§7.4's rates less 100 kbit/s, which the CiA 305 table lacks).
  std::uint16_t lss_bit_timings;
};

}  // namespace cobridge::families
