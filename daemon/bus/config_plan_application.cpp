// ConfigPlan: the application objects: 0x6000, scaling, preset, CAMs, work
// area and filters. See config_plan_builder.hpp.
#include "bus/config_plan_builder.hpp"

#include <algorithm>
#include <utility>

namespace cobridge::bus::plan_detail {

[[nodiscard]] bool Builder::scaling_requested() const {
  return dev_.scaling && (dev_.scaling->units_per_rev || dev_.scaling->total_range);
}

void Builder::operating_parameters() {
  std::uint32_t value = 0;
  std::uint32_t mask = 0;
  std::string label;
  auto name = [&label](const char* n) {
    if (!label.empty()) label += ", ";
    label += n;
  };
  if (dev_.direction) {  // J§1.4.1, E§5.3, F§7.5 bit 0
    mask |= 0x1u;
    value |= static_cast<std::uint32_t>(*dev_.direction);
    name("direction");
  }
  if (scaling_requested()) {  // bit 2, polarity per family
    mask |= 0x4u;
    value |= profile_.scaling_bit(true);
    name("scaling");
  }
  if (dev_.position_filter && profile_.position_filter_in_operating_parameter) {  // J§1.4.1 bits 14..12
    if (*dev_.position_filter > 7) {
      error("position_filter", std::to_string(*dev_.position_filter) + " is outside 0..7 (J§1.4.1 bits 14..12)");
    } else {
      mask |= 0x7000u;
      value |= std::uint32_t{*dev_.position_filter} << 12;
      name("position_filter");
    }
  }
  if (mask == 0) return;
  add_bits(label, device::FamilyProfile::operating_parameters(), value, mask, bit(StoreGroup::application));
}

void Builder::scaling() {
  if (!dev_.scaling) return;
  constexpr auto kApp = bit(StoreGroup::application);
  // 0x6001 before 0x6002: the device derives one from the other (J§1.4.2, E§5.4/5.5).
  if (dev_.scaling->units_per_rev)
    add_value("scaling units_per_rev", device::FamilyProfile::units_per_revolution(), *dev_.scaling->units_per_rev,
              kApp);
  if (dev_.scaling->total_range)
    add_value("scaling total_range", device::FamilyProfile::total_range(), *dev_.scaling->total_range, kApp);
}

[[nodiscard]] std::string Builder::channel_suffix(std::uint8_t ch) const {
  return profile_.channels > 1 ? " (channel " + std::to_string(ch) + ")" : std::string{};
}

void Builder::preset() {
  if (!dev_.preset) return;
  // One preset for the shaft: every channel of a 2-channel rotary gets it.
  for (std::uint8_t ch = 1; ch <= profile_.channels; ++ch)
    add_value("preset" + channel_suffix(ch), profile_.preset(ch), *dev_.preset, bit(StoreGroup::application));
}

void Builder::cams() {
  if (dev_.cams.empty()) return;
  constexpr auto kApp = bit(StoreGroup::application);
  std::array<std::uint32_t, 3> enable_value{}, enable_mask{}, polarity_value{}, polarity_mask{};
  for (const config::Cam& cam : dev_.cams) {
    const std::string name = "cam " + std::to_string(cam.index);
    const auto slot = profile_.cam_slot(cam.index);
    if (!slot) {
      error(name, std::string(profile_.cam_limit_text()));
      continue;
    }
    // Limits first, switches after: a CAM is not enabled on stale limits.
    if (cam.low) add_value(name + " low", device::FamilyProfile::cam_low(*slot), *cam.low, kApp);
    if (cam.high) add_value(name + " high", device::FamilyProfile::cam_high(*slot), *cam.high, kApp);
    if (cam.hysteresis)
      add_value(name + " hysteresis", device::FamilyProfile::cam_hysteresis(*slot), *cam.hysteresis, kApp);
    const std::uint32_t b = 1u << (slot->number - 1);
    if (cam.enabled) {
      enable_mask[slot->channel] |= b;
      if (*cam.enabled) enable_value[slot->channel] |= b;
    }
    if (cam.polarity) {
      polarity_mask[slot->channel] |= b;
      if (*cam.polarity == config::CamPolarity::inverted) polarity_value[slot->channel] |= b;
    }
  }
  for (std::uint8_t ch = 1; ch <= profile_.channels; ++ch) {
    if (enable_mask[ch] != 0)
      add_bits("cam enable" + channel_suffix(ch), device::FamilyProfile::cam_enable(ch), enable_value[ch],
               enable_mask[ch], kApp);
    if (polarity_mask[ch] != 0)
      add_bits("cam polarity" + channel_suffix(ch), device::FamilyProfile::cam_polarity(ch), polarity_value[ch],
               polarity_mask[ch], kApp);
  }
}

void Builder::work_area() {
  if (!dev_.work_area) return;
  constexpr auto kApp = bit(StoreGroup::application);
  for (std::uint8_t ch = 1; ch <= profile_.channels; ++ch) {
    if (dev_.work_area->low)
      add_value("work_area low" + channel_suffix(ch), device::FamilyProfile::work_area_low(ch), *dev_.work_area->low,
                kApp);
    if (dev_.work_area->high)
      add_value("work_area high" + channel_suffix(ch), device::FamilyProfile::work_area_high(ch),
                *dev_.work_area->high, kApp);
  }
}

void Builder::filters() {
  // Filters are stored with the communication group on the multiturn series (E§11 "Filter": /1, /2).
  constexpr auto kComm = bit(StoreGroup::communication);
  if (dev_.position_filter && !profile_.position_filter_in_operating_parameter) {
    if (profile_.position_filter)
      add_value("position_filter", *profile_.position_filter, *dev_.position_filter, kComm);
    else
      error("position_filter", "the " + std::string(profile_.series) + " has no position filter (" +
                                   std::string(profile_.manual) + "§7.5 has no filter object)");
  }
  if (dev_.speed_filter) {
    if (profile_.speed_filter)
      add_value("speed_filter", *profile_.speed_filter, *dev_.speed_filter, kComm);
    else
      error("speed_filter", "only the multiturn series has a speed filter (E§5.2 0x2010/2)");
  }
}

}  // namespace cobridge::bus::plan_detail
