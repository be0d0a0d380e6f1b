#include "device/family_profile.hpp"

#include <algorithm>
#include <array>

#include "families/family_traits.hpp"
#include "families/ifm_rm.hpp"
#include "families/novotechnik_multiturn.hpp"
#include "families/novotechnik_rotary.hpp"

namespace cobridge::device {

namespace {

using families::FamilyId;
namespace fam = families;

// J§1.8: position 0x7FF0 ("beyond measuring range") on a position or sensor error.
constexpr std::array<std::int32_t, 1> kRotaryErrorPositions{fam::kRotaryErrorPosition};
// E§9.1: unknown/hardware/measurement error, overflow, underflow.
constexpr std::array<std::int32_t, 3> kMultiturnErrorPositions{
    fam::kMultiturnErrorPosition, fam::kMultiturnOverflowPosition, fam::kMultiturnUnderflowPosition};

// What every profile takes from its family's facts (families).
void apply_family(FamilyProfile& p, const fam::Family& f) {
  p.family = &f;
  p.name = f.name;
  p.series = f.series;
  p.manual = f.manual;
  p.store = f.store;
  p.scaling_on_bit_value = f.scaling_on_bit_value;
  p.cams_per_channel = f.models.front().cams_per_channel;
  p.node_id_object = ObjectRef{f.addressing.node_id_index, 0};
  p.node_id_encoding = f.addressing.node_id_offset == 1 ? NodeIdEncoding::minus_one : NodeIdEncoding::direct;
  p.bitrate_object = ObjectRef{f.addressing.bitrate_index, 0};
  p.bitrate_encoding = f.addressing.bitrate_is_table_index ? BitRateEncoding::ifm_index : BitRateEncoding::kbit_per_s;
  p.bitrates = f.addressing.bitrates;
  const fam::FamilyTraits& t = fam::traits(f.id);
  if (t.position_alias) p.position_alias = ObjectRef{t.position_alias->index, t.position_alias->sub(1)};
  p.speed_unit = t.speed_unit;
}

FamilyProfile rotary(std::uint8_t channels, bool legacy) {
  FamilyProfile p;
  apply_family(p, fam::kNovotechnikRotary);
  p.channels = channels == 2 ? 2 : 1;
  p.legacy_rsx_rfx = legacy;
  p.position_type = DataType::kInteger32;  // J§1.3.2 0x6020
  p.error_positions = kRotaryErrorPositions;
  p.position_filter_in_operating_parameter = true;  // J§1.4.1 bits 14..12
  if (legacy) p.store.node_id = fam::kRotaryLegacyNodeIdStoreSub;  // J§1.12 V10
  p.heartbeat = HeartbeatSupport::uncertain;  // J§1.2.2 vs J§1.3.1 0x1017
  return p;
}

FamilyProfile multiturn() {
  FamilyProfile p;
  apply_family(p, fam::kNovotechnikMultiturn);
  p.position_type = DataType::kInteger32;  // E§4.2 0x6004
  p.error_positions = kMultiturnErrorPositions;
  p.temperature = ObjectRef{0x2002, 0};
  p.voltage = ObjectRef{0x2003, 0};
  p.position_filter = ObjectRef{0x2010, 1};
  p.speed_filter = ObjectRef{0x2010, 2};
  return p;
}

FamilyProfile ifm() {
  FamilyProfile p;
  apply_family(p, fam::kIfmRm);
  p.position_type = DataType::kUnsigned32;  // F§7.5 0x6004
  p.position_value_mask = 0x3FFFFFFFu;
  p.limit_switch_min_bit = 30;  // F§7.4 0x2104
  p.limit_switch_max_bit = 31;  // F§7.4 0x2105
  p.speed_enable = ObjectRef{0x3010, 1};
  p.has_alarms_warnings = false;  // F§4
  p.event_timer_alias = ObjectRef{0x6200, 0};
  p.save_with_reset = ObjectRef{fam::kIfmSaveWithResetObject, 0};
  p.cams_stored = false;  // F§6.3.1 lists no 0x63xx object
  // F gives no entry limit; CiA 301 allows 64 one-bit entries in 8 bytes.
  p.max_pdo_entries = 64;
  p.tpdo2_sync_only = false;  // F§7.3 0x1801 has the full record
  p.rtr_transmission = true;  // F§7.3 transmission types 252/253
  return p;
}

}  // namespace

ObjectRef FamilyProfile::position(std::uint8_t channel) const noexcept {
  if (family == nullptr) return {0x6004, 0};  // CiA 406
  const fam::ChannelObject o = fam::traits(family->id).position;  // J§1.3.2, E§4.2, F§7.5
  return {o.index, o.sub(channel)};
}

ObjectRef FamilyProfile::speed(std::uint8_t channel) const noexcept { return {0x6030, channel}; }

ObjectRef FamilyProfile::preset(std::uint8_t channel) const noexcept {
  if (family == nullptr) return {0x6003, 0};  // CiA 406
  const fam::ChannelObject o = fam::traits(family->id).preset;  // J§1.3.2, E§4.2, F§7.5
  return {o.index, o.sub(channel)};
}

DataType FamilyProfile::preset_type() const noexcept {
  const bool is_signed = family != nullptr && fam::traits(family->id).preset_signed;
  return is_signed ? DataType::kInteger32 : DataType::kUnsigned32;
}

ObjectRef FamilyProfile::cam_low(CamSlot slot) noexcept {
  return {static_cast<std::uint16_t>(0x6310 + slot.number - 1), slot.channel};
}
ObjectRef FamilyProfile::cam_high(CamSlot slot) noexcept {
  return {static_cast<std::uint16_t>(0x6320 + slot.number - 1), slot.channel};
}
ObjectRef FamilyProfile::cam_hysteresis(CamSlot slot) noexcept {
  return {static_cast<std::uint16_t>(0x6330 + slot.number - 1), slot.channel};
}

std::optional<CamSlot> FamilyProfile::cam_slot(std::uint8_t cam_index) const noexcept {
  if (cam_index == 0) return std::nullopt;
  const unsigned zero_based = cam_index - 1u;
  const unsigned channel = zero_based / cams_per_channel + 1u;
  if (channel > channels) return std::nullopt;
  return CamSlot{static_cast<std::uint8_t>(channel), static_cast<std::uint8_t>(zero_based % cams_per_channel + 1u)};
}

std::string_view FamilyProfile::cam_limit_text() const noexcept {
  if (family == nullptr) return "CiA 406 defines at most 8 CAMs per channel";
  switch (family->id) {
    case FamilyId::novotechnik_rotary:
      return channels == 2 ? "the 2-channel rotary series has 4 CAMs per channel: 1..4 on channel 1, 5..8 on "
                             "channel 2 (J§1.2.3)"
                           : "the 1-channel rotary series has 4 CAMs (J§1.2.3)";
    case FamilyId::novotechnik_multiturn: return "the multiturn series has 4 CAMs (E§3.4)";
    case FamilyId::ifm_rm: return "the ifm RM series has 8 CAMs (F§7.5)";
  }
  return "CiA 406 defines at most 8 CAMs per channel";
}

SignalMapping FamilyProfile::mapping_entry(config::Signal signal, std::uint8_t channel) const noexcept {
  if (channel == 0 || channel > channels) return {0, "the device has no such channel"};
  switch (signal) {
    case config::Signal::position: return {device::mapping_entry(position(channel), 32), {}};
    case config::Signal::speed: return {device::mapping_entry(speed(channel), 16), {}};
    case config::Signal::cam: return {device::mapping_entry(cam_state(channel), 8), {}};
    case config::Signal::work_area: return {device::mapping_entry(work_area_state(channel), 8), {}};
    case config::Signal::alarms:
      if (!has_alarms_warnings) return {0, "the ifm RM series reports no alarms (F§4)"};
      return {device::mapping_entry(alarms(), 16), {}};
    case config::Signal::warnings:
      if (!has_alarms_warnings) return {0, "the ifm RM series reports no warnings (F§4)"};
      return {device::mapping_entry(warnings(), 16), {}};
    case config::Signal::temperature:
      if (!temperature) return {0, "only the multiturn series has a temperature object (E§4.3 0x2002)"};
      return {device::mapping_entry(*temperature, 16), {}};
    case config::Signal::voltage:
      if (!voltage) return {0, "only the multiturn series has a supply-voltage object (E§4.3 0x2003)"};
      return {device::mapping_entry(*voltage, 16), {}};
    case config::Signal::raw: break;
  }
  return {0, "a raw mapping entry is not a semantic signal"};
}

bool FamilyProfile::is_position_entry(std::uint32_t entry) const noexcept {
  const ObjectRef object{static_cast<std::uint16_t>(entry >> 16), static_cast<std::uint8_t>((entry >> 8) & 0xFFu)};
  if (position_alias && object == *position_alias) return true;
  for (std::uint8_t ch = 1; ch <= channels; ++ch) {
    if (object == position(ch)) return true;
  }
  return false;
}

std::uint32_t FamilyProfile::scaling_bit(bool on) const noexcept {
  return (on == scaling_on_bit_value) ? 0x4u : 0x0u;
}

std::uint32_t FamilyProfile::encode_node_id(std::uint8_t node_id) const noexcept {
  if (node_id_encoding == NodeIdEncoding::minus_one) return node_id == 0 ? 0u : node_id - 1u;
  return node_id;
}

std::uint8_t FamilyProfile::decode_node_id(std::uint32_t value) const noexcept {
  if (node_id_encoding == NodeIdEncoding::minus_one) return static_cast<std::uint8_t>((value & 0x7Fu) + 1u);
  return static_cast<std::uint8_t>(value & 0xFFu);
}

std::optional<std::uint32_t> FamilyProfile::encode_bitrate(std::uint16_t kbit) const noexcept {
  if (bitrate_encoding == BitRateEncoding::ifm_index) {
    const auto it = std::find(bitrates.begin(), bitrates.end(), kbit);
    if (it == bitrates.end()) return std::nullopt;
    return static_cast<std::uint32_t>(it - bitrates.begin());
  }
  if (std::find(bitrates.begin(), bitrates.end(), kbit) == bitrates.end()) return std::nullopt;
  return kbit;
}

std::optional<std::uint16_t> FamilyProfile::decode_bitrate(std::uint32_t value) const noexcept {
  if (bitrate_encoding == BitRateEncoding::ifm_index) {
    if (value >= bitrates.size()) return std::nullopt;
    return bitrates[value];
  }
  if (value > 0xFFFFu) return std::nullopt;
  const auto kbit = static_cast<std::uint16_t>(value);
  if (std::find(bitrates.begin(), bitrates.end(), kbit) == bitrates.end()) return std::nullopt;
  return kbit;
}

bool FamilyProfile::transmission_type_allowed(std::uint8_t tpdo, std::uint8_t type) const noexcept {
  if (tpdo == 0 || tpdo > tpdo_count) return false;
  if (type <= 240) return true;  // 0 = off on Novotechnik, acyclic sync on ifm; 1..240 sync
  if (tpdo == 2 && tpdo2_sync_only) return false;
  if (type == 254 || type == 255) return true;
  if (type == 252 || type == 253) return rtr_transmission;
  return false;
}

bool FamilyProfile::is_error_position(std::int32_t position) const noexcept {
  return std::find(error_positions.begin(), error_positions.end(), position) != error_positions.end();
}

FamilyProfile make_family_profile(FamilyId family, std::uint8_t channels, bool legacy_rsx_rfx) noexcept {
  switch (family) {
    case FamilyId::novotechnik_rotary: return rotary(channels, legacy_rsx_rfx);
    case FamilyId::novotechnik_multiturn: return multiturn();
    case FamilyId::ifm_rm: break;
  }
  return ifm();
}

std::optional<FamilyProfile> family_profile_for(const DeviceDescription& description) noexcept {
  const fam::Family* family = fam::find_family(description.selection.family);
  if (family == nullptr) return std::nullopt;
  std::uint8_t channels = 1;
  if (fam::traits(family->id).channel_count_in_eds) {
    // J§1.3.2: 0x6020/0 is the number of channels (2, or 1 on 1-channel variants).
    if (const ObjectDesc* count = description.find(0x6020, 0)) {
      if (auto v = count->default_for_node(0); v && *v == 2) channels = 2;
    }
  }
  const std::uint32_t product = description.device_info.product_number;
  const fam::Model* model = family->model_of(product);
  const bool legacy = model != nullptr && model->legacy_rsx_rfx;
  return make_family_profile(family->id, channels, legacy);
}

}  // namespace cobridge::device
