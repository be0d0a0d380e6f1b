// FamilyProfile: what the gateway must know about one encoder family beyond
// its EDS, i.e. the facts an EDS cannot express: which object carries the
// position on this family, how the node-ID and bit rate are encoded, which
// polarity the scaling bit has, which 0x1010 sub-index stores which
// parameters, how many CAMs a channel has, which semantic signal maps to which
// object. Every fact cites the manual section it comes from (J = Novotechnik
// rotary, E = Novotechnik multiturn, F = ifm RM8/RM9: the manuals' own
// section numbers).
// Identity, addressing, storage and scaling facts come from the family's
// module in families; this adds the object-dictionary view.
//
// A profile is a small immutable value built from the EDS [Cobridge] Family
// string (family_profile_for) or directly (make_family_profile). It is built
// off the hot path (configuration, commissioning) and may then be read from
// any thread; nothing in it allocates after construction.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

#include "config/config.hpp"
#include "device/eds.hpp"
#include "families/family.hpp"
#include "families/family_traits.hpp"
#include "families/ifm_rm.hpp"
#include "families/novotechnik.hpp"

namespace cobridge::device {

struct ObjectRef {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  friend constexpr bool operator==(const ObjectRef&, const ObjectRef&) = default;
};

// CiA 301 §7.4.8.1 mapping entry layout: index<<16 | sub<<8 | bit length.
[[nodiscard]] constexpr std::uint32_t mapping_entry(ObjectRef object, std::uint8_t bits) noexcept {
  return (std::uint32_t{object.index} << 16) | (std::uint32_t{object.sub} << 8) | bits;
}

// The 'save' signature of CiA 301 object 0x1010 and ifm's "save parameters
// with reset" code: the families' facts (families).
inline constexpr std::uint32_t kSaveSignature = families::kSaveSignature;
inline constexpr std::uint32_t kIfmSaveWithResetCode = families::kIfmSaveWithResetCode;

// 0.1 °/s (E§3.4; assumed for J) or steps per second (F§7.4 0x3011).
using SpeedUnit = families::SpeedUnit;

enum class NodeIdEncoding : std::uint8_t {
  direct,     // object value = node-ID (J§1.3.3 / E§4.3 0x2000)
  minus_one,  // object value = node-ID - 1 (F§7.4 0x3000: "always add 1")
};

enum class BitRateEncoding : std::uint8_t {
  kbit_per_s,  // UNSIGNED16 in kbit/s (J§1.3.3 / E§4.3 0x2001)
  ifm_index,   // UNSIGNED8 0..7 = 20/50/100/125/250/500/800/1000 (F§7.4 0x3001)
};

enum class HeartbeatSupport : std::uint8_t {
  yes,
  // J§1.2.2 says "heartbeat: no" although 0x1017 is listed (J§1.3.1): write
  // 0x1017 and fall back to node guarding when the device refuses it.
  uncertain,
};

// 0x1010 sub-index that stores each group of parameters (J§1.10, E§11, F§6.3).
// Communication parameters are stored with /2 rather than /1 on Novotechnik
// because /1 sets the TPDO COB-IDs back to default (E§11 table, "D").
using StoreSubs = families::StoreSubs;

// A CAM as the configuration numbers it (1..8) located on its channel.
struct CamSlot {
  std::uint8_t channel = 1;  // position channel, 1-based
  std::uint8_t number = 1;   // CAM number within the channel, 1-based
};

// Either a mapping entry or why the family cannot map the signal.
struct SignalMapping {
  std::uint32_t entry = 0;
  std::string_view error;  // empty on success; static text with a citation
  [[nodiscard]] bool ok() const noexcept { return error.empty(); }
};

struct FamilyProfile {
  const families::Family* family = nullptr;  // the family's module (never nullptr in a built profile)
  std::string_view name;    // EDS [Cobridge] Family value, e.g. "novotechnik-rotary"
  std::string_view series;  // for messages: "rotary series", "multiturn series", "ifm RM series"
  std::string_view manual;  // citation key: "J", "E", "F"
  std::uint8_t channels = 1;
  // RSX-7900 / RFX-6900 firmware (J§1.12 V10): node-ID stored with 0x1010/1.
  bool legacy_rsx_rfx = false;

  // --- position and speed ---
  DataType position_type = DataType::kInteger32;
  // ifm: bits 30/31 are the limit-switch flags when 0x2100 bits 1/2 are set
  // (F§7.4 0x2104/0x2105); the value is in bits 29..0.
  std::uint32_t position_value_mask = 0xFFFFFFFFu;
  std::optional<std::uint8_t> limit_switch_min_bit;
  std::optional<std::uint8_t> limit_switch_max_bit;
  // Multiturn: the default mapping names 0x6020/1 (E§4.1 0x1A00/1) although
  // the position object is 0x6004 (E§4.2); treat 0x6020/1 as an alias.
  std::optional<ObjectRef> position_alias;
  std::span<const std::int32_t> error_positions;  // J§1.8, E§9.1; ifm documents none
  SpeedUnit speed_unit = SpeedUnit::deci_degree_per_s;
  // ifm: speed is off by default and enabled by 0x3010/1 = 1 (F§7.4).
  std::optional<ObjectRef> speed_enable;

  // --- functions ---
  std::uint8_t cams_per_channel = 4;
  bool has_alarms_warnings = true;  // 0x6503/0x6505; ifm: "not indicated" (F§4)
  std::optional<ObjectRef> temperature;  // E§4.3 0x2002, 0.1 °C
  std::optional<ObjectRef> voltage;      // E§4.3 0x2003, 0.1 V
  // 0x6000 bit 2 value that switches scaling on: J§1.4.1 1, E§5.3 0 (as printed), F§7.5 SFC 1.
  bool scaling_on_bit_value = true;
  // Rotary: moving average in 0x6000 bits 14..12 (J§1.4.1).
  bool position_filter_in_operating_parameter = false;
  std::optional<ObjectRef> position_filter;  // E§5.1 0x2010/1
  std::optional<ObjectRef> speed_filter;     // E§5.2 0x2010/2
  // ifm: 0x6200 is the event timer "of the corresponding PDOs" next to 0x1800/5 (F§7.5).
  std::optional<ObjectRef> event_timer_alias;

  // --- addressing and storage ---
  ObjectRef node_id_object{0x2000, 0};
  NodeIdEncoding node_id_encoding = NodeIdEncoding::direct;
  ObjectRef bitrate_object{0x2001, 0};
  BitRateEncoding bitrate_encoding = BitRateEncoding::kbit_per_s;
  // The bit rates the family offers, kbit/s (by index for ifm_index).
  std::span<const std::uint16_t> bitrates = families::kNovotechnikBitRates;
  StoreSubs store;
  // 'save' is accepted in pre-operational only (J§1.10, E§11; F§6.1.1).
  bool store_only_pre_operational = true;
  std::optional<ObjectRef> save_with_reset;  // ifm 0x2300 (F§6.3.4)
  HeartbeatSupport heartbeat = HeartbeatSupport::yes;
  // ifm: CAM settings are not among the stored objects (F§6.3.1), so they are
  // lost at power-off and must be applied after every boot.
  bool cams_stored = true;

  // --- PDOs ---
  std::uint8_t tpdo_count = 2;
  std::uint8_t max_pdo_entries = 5;  // J§1.7.2, E§8.2
  std::uint8_t max_pdo_bytes = 8;
  // Novotechnik TPDO2 is synchronous only (J§1.3.1 / E§4.1 0x1801/2).
  bool tpdo2_sync_only = true;
  // ifm supports the RTR types 252/253 (F§7.3); Novotechnik does not.
  bool rtr_transmission = false;

  // --- objects ---
  [[nodiscard]] ObjectRef position(std::uint8_t channel = 1) const noexcept;
  [[nodiscard]] ObjectRef speed(std::uint8_t channel = 1) const noexcept;
  [[nodiscard]] ObjectRef preset(std::uint8_t channel = 1) const noexcept;
  [[nodiscard]] DataType preset_type() const noexcept;
  [[nodiscard]] static constexpr ObjectRef operating_parameters() noexcept { return {0x6000, 0}; }
  [[nodiscard]] static constexpr ObjectRef units_per_revolution() noexcept { return {0x6001, 0}; }
  [[nodiscard]] static constexpr ObjectRef total_range() noexcept { return {0x6002, 0}; }
  [[nodiscard]] static constexpr ObjectRef cam_state(std::uint8_t channel = 1) noexcept { return {0x6300, channel}; }
  [[nodiscard]] static constexpr ObjectRef cam_enable(std::uint8_t channel = 1) noexcept { return {0x6301, channel}; }
  [[nodiscard]] static constexpr ObjectRef cam_polarity(std::uint8_t channel = 1) noexcept { return {0x6302, channel}; }
  // `number` is the CAM within its channel (CamSlot::number).
  [[nodiscard]] static ObjectRef cam_low(CamSlot slot) noexcept;
  [[nodiscard]] static ObjectRef cam_high(CamSlot slot) noexcept;
  [[nodiscard]] static ObjectRef cam_hysteresis(CamSlot slot) noexcept;
  [[nodiscard]] static constexpr ObjectRef work_area_state(std::uint8_t channel = 1) noexcept { return {0x6400, channel}; }
  [[nodiscard]] static constexpr ObjectRef work_area_low(std::uint8_t channel = 1) noexcept { return {0x6401, channel}; }
  [[nodiscard]] static constexpr ObjectRef work_area_high(std::uint8_t channel = 1) noexcept { return {0x6402, channel}; }
  [[nodiscard]] static constexpr ObjectRef alarms() noexcept { return {0x6503, 0}; }
  [[nodiscard]] static constexpr ObjectRef warnings() noexcept { return {0x6505, 0}; }

  // CAM 1..8 of the configuration: rotary 1..4 = channel 1, 5..8 = channel 2
  // (only on 2-channel variants); multiturn 1..4; ifm 1..8. nullopt if the
  // family (or this variant) has no such CAM.
  [[nodiscard]] std::optional<CamSlot> cam_slot(std::uint8_t cam_index) const noexcept;
  // "the multiturn series has 4 CAMs (E§3.4)", for error messages.
  [[nodiscard]] std::string_view cam_limit_text() const noexcept;

  // Semantic signal -> mapping entry for channel `channel`. Signal::raw is
  // not resolved here (the caller has the raw entry).
  [[nodiscard]] SignalMapping mapping_entry(config::Signal signal, std::uint8_t channel = 1) const noexcept;
  // True when `entry` maps the position of this family (including the alias).
  [[nodiscard]] bool is_position_entry(std::uint32_t entry) const noexcept;

  // Bit 2 of 0x6000 for scaling on/off with this family's polarity.
  [[nodiscard]] std::uint32_t scaling_bit(bool on) const noexcept;

  // The value to write to node_id_object for `node_id` (1..127), and back.
  [[nodiscard]] std::uint32_t encode_node_id(std::uint8_t node_id) const noexcept;
  [[nodiscard]] std::uint8_t decode_node_id(std::uint32_t value) const noexcept;
  // The value for bitrate_object; nullopt for a rate the family lacks.
  [[nodiscard]] std::optional<std::uint32_t> encode_bitrate(std::uint16_t kbit) const noexcept;
  [[nodiscard]] std::optional<std::uint16_t> decode_bitrate(std::uint32_t value) const noexcept;

  // Whether `type` is a transmission type this family accepts on TPDO
  // `tpdo` (1 or 2).
  [[nodiscard]] bool transmission_type_allowed(std::uint8_t tpdo, std::uint8_t type) const noexcept;
  // Whether `position` is one of the family's error sentinels.
  [[nodiscard]] bool is_error_position(std::int32_t position) const noexcept;
  [[nodiscard]] bool is(families::FamilyId id) const noexcept { return family != nullptr && family->id == id; }
};

// The profile of a family. `channels` matters for the rotary series only;
// `legacy_rsx_rfx` for RSX-7900 / RFX-6900 (J§1.12 V10).
[[nodiscard]] FamilyProfile make_family_profile(families::FamilyId family, std::uint8_t channels = 1,
                                                bool legacy_rsx_rfx = false) noexcept;

// From an EDS: the family from [Cobridge] Family, the channel count from the
// default of 0x6020/0, RSX/RFX from the model that lists the product code (Model::legacy_rsx_rfx).
// nullopt when the description names no known family.
[[nodiscard]] std::optional<FamilyProfile> family_profile_for(const DeviceDescription& description) noexcept;

}  // namespace cobridge::device
