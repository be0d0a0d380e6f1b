// The 0x1010 / 0x1011 signatures: 'save', 'load' and 'kill' on the
// parameter groups each sub-index covers (storage.hpp; J§1.10, E§11,
// F§6.3), kept in the device's non-volatile file.
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

Error SimDevice::Impl::persist() const { return nv.save(nv_data); }

std::uint32_t SimDevice::Impl::save(std::uint8_t store_sub) {
  for (const device::ObjectDesc& e : desc.entries) {
    if (is_string_type(e.data_type) || !is_writable(*od, e.index, e.sub)) continue;
    const Coverage c = store_coverage(family, model.legacy_rsx_rfx, store_sub, e.index, e.sub);
    if (c == Coverage::none) continue;
    if (c == Coverage::default_value) {
      nv_data.params.erase(e.index, e.sub);
      continue;
    }
    // ifm 'load' then 'save': the factory settings reach the EEPROM (F§6.3.5).
    const std::uint64_t v =
        ifm_defaults_pending ? factory_value(e, active_node) : od->get_raw(e.index, e.sub).value_or(0);
    // A $NODEID value equal to its default is left to the default, so it
    // follows a later node-ID change as the predefined connection set does.
    if (e.default_value.plus_node_id && v == eds_default_raw(e, active_node))
      nv_data.params.erase(e.index, e.sub);
    else
      nv_data.params.set(e.index, e.sub, v);
  }
  // The preset's effect is an offset the device keeps with it (CiA 406
  // 0x6509); without it a stored preset would mean nothing after power-up.
  const std::uint16_t preset_index = traits.preset.index;
  const std::uint8_t preset_sub = traits.preset.sub(1);
  if (store_coverage(family, model.legacy_rsx_rfx, store_sub, preset_index, preset_sub) == Coverage::value) {
    for (std::size_t ch = 0; ch < channels; ++ch)
      nv_data.params.set(kOffsetKeyIndex, static_cast<std::uint8_t>(kOffsetKeySub + ch),
                         static_cast<std::uint64_t>(ifm_defaults_pending ? 0 : encoder.offset(static_cast<int>(ch))));
  }
  ifm_defaults_pending = false;
  if (persist()) return canopen::od_abort::kCannotStore;  // J/E: "data transfer error"
  return 0;
}

std::uint32_t SimDevice::Impl::load(std::uint8_t store_sub) {
  switch (traits.load) {
    case families::LoadAction::factory_after_reset:
      // F§6.3.5: factory settings, active only after a reset; EEPROM untouched.
      ifm_defaults_pending = true;
      return 0;
    case families::LoadAction::revert_to_stored: break;  // J§1.10, E§11
  }
  const NvImage& image = nv_data.params;
  load_parameters(
      [&](const device::ObjectDesc& e) {
        return store_coverage(family, model.legacy_rsx_rfx, store_sub, e.index, e.sub) != Coverage::none;
      },
      &image);
  restore_offsets(&image);
  return 0;
}

std::uint32_t SimDevice::Impl::kill(std::uint8_t store_sub) {
  auto covered = [&](const device::ObjectDesc& e) {
    return store_coverage(family, model.legacy_rsx_rfx, store_sub, e.index, e.sub) != Coverage::none;
  };
  for (const device::ObjectDesc& e : desc.entries)
    if (covered(e)) nv_data.params.erase(e.index, e.sub);
  legacy_kill = true;
  load_parameters(covered, nullptr);
  legacy_kill = false;
  const std::uint16_t preset_index = traits.preset.index;
  const std::uint8_t preset_sub = traits.preset.sub(1);
  if (store_coverage(family, model.legacy_rsx_rfx, store_sub, preset_index, preset_sub) != Coverage::none) {
    for (std::size_t ch = 0; ch < channels; ++ch)
      nv_data.params.erase(kOffsetKeyIndex, static_cast<std::uint8_t>(kOffsetKeySub + ch));
    restore_offsets(nullptr);
  }
  if (persist()) return canopen::od_abort::kCannotStore;
  return 0;
}

}  // namespace cobridge::sim
