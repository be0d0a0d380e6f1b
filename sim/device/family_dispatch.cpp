// The hooks through which a family adds to the shared runtime: one switch
// over FamilyId each, without `default`, so that -Wswitch names every hook a
// new family must fill (docs/adding-a-device.md). Values that differ by
// family are FamilyTraits (families/traits.hpp), not branches here.
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

void SimDevice::Impl::family_factory() {
  switch (family) {
    case FamilyId::novotechnik_rotary: rotary_factory(); break;
    case FamilyId::novotechnik_multiturn: multiturn_factory(); break;
    case FamilyId::ifm_rm: ifm_factory(); break;
  }
}

void SimDevice::Impl::family_adjust(canopen::EntryDef& def) const {
  switch (family) {
    case FamilyId::novotechnik_rotary: rotary_adjust(def); break;
    case FamilyId::novotechnik_multiturn: break;
    case FamilyId::ifm_rm: ifm_adjust(def); break;
  }
}

void SimDevice::Impl::family_extras() {
  switch (family) {
    case FamilyId::novotechnik_rotary: break;
    case FamilyId::novotechnik_multiturn: multiturn_extras(); break;
    case FamilyId::ifm_rm: break;
  }
}

void SimDevice::Impl::family_after_load() noexcept {
  switch (family) {
    case FamilyId::novotechnik_rotary: break;
    case FamilyId::novotechnik_multiturn: break;
    case FamilyId::ifm_rm: ifm_mirror_event_timer(); break;  // F§7.5 0x6200 follows 0x1800/5
  }
}

std::uint32_t SimDevice::Impl::family_on_write(const canopen::WriteRequest& req) {
  switch (family) {
    case FamilyId::novotechnik_rotary: return rotary_on_write(req);
    case FamilyId::novotechnik_multiturn: return multiturn_on_write(req);
    case FamilyId::ifm_rm: return ifm_on_write(req);
  }
  return 0;
}

void SimDevice::Impl::family_after_write(std::uint16_t index, std::uint8_t sub) {
  switch (family) {
    case FamilyId::novotechnik_rotary: rotary_after_write(index, sub); break;
    case FamilyId::novotechnik_multiturn: multiturn_after_write(index, sub); break;
    case FamilyId::ifm_rm: ifm_after_write(index, sub); break;
  }
}

void SimDevice::Impl::family_publish(std::size_t ch, ChannelSample& s, const ChannelSample& before, bool first) {
  switch (family) {
    case FamilyId::novotechnik_rotary: rotary_publish(ch, s, before, first); break;
    case FamilyId::novotechnik_multiturn: multiturn_publish(s, before, first); break;
    case FamilyId::ifm_rm: ifm_publish(s, before, first); break;
  }
}

void SimDevice::Impl::family_fault(FaultKind fault, TimePoint now) {
  switch (family) {
    case FamilyId::novotechnik_rotary: rotary_fault(fault, now); break;
    case FamilyId::novotechnik_multiturn: multiturn_fault(fault, now); break;
    case FamilyId::ifm_rm: ifm_fault(fault, now); break;
  }
}

void SimDevice::Impl::family_life_guarding(bool lost) {
  if (lost == life_guarding_lost) return;
  life_guarding_lost = lost;
  switch (family) {
    case FamilyId::novotechnik_rotary: break;  // J documents no reaction and no EMCY
    case FamilyId::novotechnik_multiturn: multiturn_life_guarding(lost); break;
    case FamilyId::ifm_rm: ifm_life_guarding(lost); break;
  }
  refresh_status();
}

void SimDevice::Impl::family_status() noexcept {
  switch (family) {
    case FamilyId::novotechnik_rotary: rotary_status(); break;
    case FamilyId::novotechnik_multiturn: multiturn_status(); break;
    case FamilyId::ifm_rm: break;  // F: no 0x1002, 0x6503, 0x6505
  }
}

}  // namespace cobridge::sim
