// The encoder front end as the object dictionary sets it: scaling, filters,
// CAMs, work area, limits and preset offsets per channel, and the 1 ms
// measuring cycle that publishes its samples (J§1.2.5, E§3.3).
#include "device/sim_device_impl.hpp"

#include <algorithm>
#include <bit>
#include <chrono>

#include "canopen/cob_id.hpp"
#include "canopen/sync.hpp"
#include "device/od_builder.hpp"
#include "device/storage.hpp"
#include "families/ifm_rm.hpp"

namespace cobridge::sim {

using namespace device_objects;

bool SimDevice::Impl::scaling_active() const noexcept {
  const std::uint64_t op = od->get_raw(0x6000, 0).value_or(0);
  const bool bit = (op & 0x04U) != 0;
  // J§1.4.1 and F§7.5 SFC: 1 = on. E§5.3 as printed: 0 = on.
  return bit == family_facts(family).scaling_on_bit_value;
}

void SimDevice::Impl::configure_encoder() {
  if (!od) return;
  for (std::size_t ch = 0; ch < channels; ++ch) {
    const auto s = static_cast<std::uint8_t>(ch + 1);
    ChannelConfig c;
    c.operating_parameter = static_cast<std::uint16_t>(od->get_raw(0x6000, 0).value_or(0));
    c.per_rev = static_cast<std::uint32_t>(od->get_raw(0x6001, 0).value_or(0));
    c.total = static_cast<std::uint32_t>(od->get_raw(0x6002, 0).value_or(0));
    c.position_filter = od->get_u8(0x2010, 1).value_or(0);
    c.speed_integration_ms = od->get_u16(0x6031, 2).value_or(1);
    if (traits.speed_switchable) {  // F§7.4 0x3010
      c.speed_enabled = od->get_u8(0x3010, 1).value_or(0) != 0;
      c.speed_mode = od->get_u8(0x3010, 2).value_or(0);
    }
    if (traits.limit_switch_flags) {  // F§7.4 0x2100, 0x2104, 0x2105
      const std::uint16_t op = od->get_u16(0x2100, 0).value_or(0);
      c.limit_min_enabled = (op & 0x02U) != 0;
      c.limit_max_enabled = (op & 0x04U) != 0;
      c.limit_min = od->get_u32(0x2104, 0).value_or(0);
      c.limit_max = od->get_u32(0x2105, 0).value_or(0);
    }
    c.cams.count = family_facts(family).models.front().cams_per_channel;  // J§1.2.3, E§3.4, F§7.5
    c.cams.enable = od->get_u8(0x6301, s).value_or(0);
    c.cams.polarity = od->get_u8(0x6302, s).value_or(0);
    for (std::uint8_t k = 0; k < c.cams.count; ++k) {
      c.cams.low[k] = get_int(static_cast<std::uint16_t>(0x6310 + k), s);
      c.cams.high[k] = get_int(static_cast<std::uint16_t>(0x6320 + k), s);
      c.cams.hysteresis[k] = get_int(static_cast<std::uint16_t>(0x6330 + k), s);
    }
    c.has_work_area = od->contains(0x6400, s);
    c.work_area.low = get_int(0x6401, s);
    c.work_area.high = get_int(0x6402, s);
    switch (traits.work_area_range) {
      case families::WorkAreaRange::preset_to_length:
        // J§1.4.6.1: bit 0 for "position <= preset or >= sensor length".
        c.work_area.range_min = get_int(traits.preset.index, traits.preset.sub(s));
        c.work_area.range_max = c.total != 0 ? c.total : 0x4000;
        break;
      case families::WorkAreaRange::cia406_limits:
        c.work_area.range_min = get_int(0x650A, 2);
        c.work_area.range_max = get_int(0x650A, 3);
        break;
    }
    encoder.configure(static_cast<int>(ch), c);
  }
}

void SimDevice::Impl::restore_offsets(const NvImage* image) {
  for (std::size_t ch = 0; ch < channels; ++ch) {
    const auto key_sub = static_cast<std::uint8_t>(kOffsetKeySub + ch);
    const std::uint16_t preset_index = traits.preset.index;
    const std::uint8_t preset_sub = traits.preset.sub(static_cast<std::uint8_t>(ch + 1));
    std::int64_t off = 0;
    if (image != nullptr)
      if (const auto v = image->get(kOffsetKeyIndex, key_sub)) off = static_cast<std::int64_t>(*v);
    encoder.restore_offset(static_cast<int>(ch), off, get_int(preset_index, preset_sub));
  }
}

void SimDevice::Impl::measure(TimePoint now) {
  bool changed = false;
  for (std::size_t ch = 0; ch < channels; ++ch) {
    ChannelSample s = encoder.measure(static_cast<int>(ch), now);
    const ChannelSample before = last[ch];
    family_publish(ch, s, before, first_measure);
    changed = changed || first_measure || s.position != before.position || s.speed != before.speed ||
              s.cams != before.cams || s.work_area != before.work_area;
    last[ch] = s;
  }
  first_measure = false;
  if (traits.condition_monitoring) condition_cycle(last[0], now);
  for (std::size_t i = 0; i < 2; ++i)
    if (tpdo_present[i]) tpdo[i].on_measure(now, changed);
}

}  // namespace cobridge::sim
