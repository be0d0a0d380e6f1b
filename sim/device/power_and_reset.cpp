// Power-up, boot-up and the NMT resets: which stored or factory values each
// stage loads and which node-ID and bit rate become active.
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

Error SimDevice::Impl::power_on(TimePoint now) {
  if (powered) return {};
  now_cache = now;
  if (Error e = nv.load(nv_data)) return e;

  // The node-ID the device boots with: what was stored, else the factory one.
  active_node = factory_node;
  const auto& addressing = family_facts(family).addressing;
  if (const auto stored = nv_data.params.get(addressing.node_id_index, 0))
    active_node = node_of_value(addressing, *stored);

  if (Error e = build_od()) return e;
  load_parameters([](const device::ObjectDesc&) { return true; }, &nv_data.params);
  if (!nv_data.params.get(addressing.node_id_index, 0)) node_to_od(factory_node);
  pending_node = active_node;
  active_kbit = pending_kbit = kbit_from_od();

  encoder.set_family(family, Resolution{static_cast<std::uint32_t>(od->get_raw(0x6501, 0).value_or(0x4000)),
                                        static_cast<std::uint32_t>(od->get_raw(0x6502, 0).value_or(1))});
  if (Error e = encoder.set_motion(spec.motion, now)) return e;

  canopen::SdoServerConfig sdo_config;
  sdo_config.segmented = spec.segmented_sdo;
  sdo = std::make_unique<canopen::SdoServer>(tx, *od, cob::valid_node_id(active_node) ? active_node : 1, sdo_config);
  if (spec.lss != LssProfile::none) lss.emplace(tx, identity_of(), active_node, lss_features(spec, family));
  if (lss) lss->set_store_handler([this](const canopen::LssSlave& s) { return lss_store(s); });
  emcy.attach(od.get(), &Impl::emcy_thunk, this);

  clear_runtime_state();
  powered = true;
  first_measure = true;
  configure_encoder();
  restore_offsets(&nv_data.params);
  if (traits.condition_monitoring) condition_power_up(now);
  // The first measuring cycle runs before the boot-up, so the position
  // objects hold a real value from the first SDO read on.
  measure(now);
  next_measure = now + kMeasuringCycle;
  boot(now);
  return {};
}

void SimDevice::Impl::clear_runtime_state() {
  TpdoPolicy policy;
  policy.type0_off = traits.tpdo_type0_off;
  policy.type255_every_cycle = traits.tpdo_async_every_cycle;
  policy.on_change = !traits.tpdo_async_every_cycle;
  policy.rtr = traits.rtr_transmission;
  for (auto& t : tpdo) t.set_policy(policy);
  tpdo_present = {true, !traits.tpdo2_needs_variant || spec.ifm_c6};

  faults = 0;
  over_range_latched = under_range_latched = false;
  alarms = warnings = 0;
  status = 0;
  life_guarding_lost = false;
  can_state = CanControllerState::error_active;  // a fresh controller after power-up
  ifm_defaults_pending = false;
  reset_node_requested = false;
  guard = canopen::GuardResponder{};
  guard.set_callback([this](canopen::GuardResponder::EventKind kind, TimePoint) {
    family_life_guarding(kind == canopen::GuardResponder::EventKind::life_guarding_lost);
  });
  emcy.set_error_register(0);
}

void SimDevice::Impl::power_off() noexcept {
  powered = false;
  abort_sdo_index = 0;  // injected SDO faults do not survive the power
  ignore_sdo_index = 0;
  ignore_nmt_starts = 0;
  late_lss.clear();
  lss.reset();
  sdo.reset();
  emcy.attach(nullptr, nullptr, nullptr);
  od.reset();
  for (auto& t : tpdo) t.set_running(false, now_cache);
  layout_ok = {false, false};
  next_heartbeat = next_measure = canopen::kNever;
}

void SimDevice::Impl::boot(TimePoint now) {
  nmt.power_on();
  if (od->contains(kNmtStartup, 0))
    nmt.set_autostart((od->get_u32(kNmtStartup, 0).value_or(0) & kAutostartBit) != 0);
  const bool configured = cob::valid_node_id(active_node);
  sdo->set_enabled(configured);
  if (configured) sdo->set_node_id(active_node);
  guard.reset_communication();
  configure_guard();
  emcy.reset();
  for (std::size_t i = 0; i < 2; ++i) reconfigure_tpdo(i, now);
  if (!configured) {
    // CiA 305: without a node-ID the device waits in initialisation, silent
    // except for LSS, until a node-ID is configured.
    if (lss) lss->set_ignore(false);
    next_heartbeat = canopen::kNever;
    refresh_status();
    return;
  }
  const auto from = nmt.state();
  (void)nmt.complete_initialisation();
  send(canopen::make_boot_up(active_node), TruthRecord::Kind::boot_up);
  on_nmt_change(from, now);
  restart_heartbeat(now);
}

void SimDevice::Impl::reset_communication(TimePoint now) { reset_communication(now, &nv_data.params); }

void SimDevice::Impl::reset_communication(TimePoint now, const NvImage* image) {
  now_cache = now;
  active_node = pending_node;
  active_kbit = pending_kbit;
  // Communication area back to `image` (the stored one, or none = the
  // defaults), with the new node-ID in the predefined connection set.
  load_parameters([](const device::ObjectDesc& e) { return e.index >= 0x1000 && e.index < 0x2000; }, image);
  if (lss) {
    const canopen::LssSlaveFeatures f = lss->features();
    lss.emplace(tx, identity_of(), active_node, f);
    lss->set_store_handler([this](const canopen::LssSlave& s) { return lss_store(s); });
  }
  boot(now);
}

void SimDevice::Impl::reset_node(TimePoint now) {
  now_cache = now;
  // A pending node-ID / bit rate (SDO or LSS) survives into the restart and
  // becomes active (J§1.6.1, E§7.1).
  const std::uint8_t node = pending_node;
  const std::uint16_t kbit = pending_kbit;
  // ifm 'load' (F§6.3.5, F§7.3 0x1011): this reset activates the factory
  // settings without touching the EEPROM, so every stage of the reset below
  // (application and communication area, the preset offset) takes the
  // defaults, not the stored image.
  const NvImage* image = ifm_defaults_pending ? nullptr : &nv_data.params;
  ifm_defaults_pending = false;
  load_parameters([](const device::ObjectDesc&) { return true; }, image);
  const auto& addressing = family_facts(family).addressing;
  const bool stored_first = traits.address_activation == families::AddressActivation::stored_first;
  if (!stored_first || !nv_data.params.get(addressing.node_id_index, 0)) {
    pending_node = node;
    pending_kbit = kbit;
  } else {
    pending_node = node_from_od();
    pending_kbit = kbit_from_od();
  }
  node_to_od(pending_node);
  kbit_to_od(pending_kbit);
  faults &= ~(fault_bit(FaultKind::over_range) | fault_bit(FaultKind::under_range));
  encoder.reset();
  configure_encoder();
  restore_offsets(image);
  measure(now);
  reset_communication(now, image);
}

}  // namespace cobridge::sim
