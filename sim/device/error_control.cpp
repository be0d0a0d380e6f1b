// NMT state changes, heartbeat and node guarding, and the status objects
// (0x1001, 0x1002, 0x6503, 0x6505) the fault state sets.
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

void SimDevice::Impl::on_nmt_change(NmtState from, TimePoint now) {
  (void)from;
  const bool operational = nmt.state() == NmtState::operational;
  for (std::size_t i = 0; i < 2; ++i) tpdo[i].set_running(operational && tpdo_present[i] && layout_ok[i], now);
  // J§1.5, E§6: LSS only in stopped or pre-operational.
  if (lss) lss->set_ignore(operational);
  refresh_status();
}

void SimDevice::Impl::configure_guard() {
  const auto gt = std::chrono::milliseconds(od->get_u16(kGuardTime, 0).value_or(0));
  guard.configure(gt, od->get_u8(kLifeTimeFactor, 0).value_or(0));
}

void SimDevice::Impl::restart_heartbeat(TimePoint now) {
  const std::uint16_t ms = od ? od->get_u16(kHeartbeatTime, 0).value_or(0) : 0;
  next_heartbeat = ms == 0 || !cob::valid_node_id(active_node) ? canopen::kNever : now + std::chrono::milliseconds(ms);
}

void SimDevice::Impl::refresh_status() noexcept {
  if (!od) return;
  family_status();
  if (od->contains(kStatusRegister, 0)) {
    std::uint32_t nmt_bits = 0;  // J§1.9.1, E§10.1 bits 0-1
    switch (nmt.state()) {
      case NmtState::boot_up: nmt_bits = 0; break;
      case NmtState::pre_operational: nmt_bits = 1; break;
      case NmtState::operational: nmt_bits = 2; break;
      case NmtState::stopped: nmt_bits = 3; break;
    }
    (void)od->set_u32(kStatusRegister, 0, ((status | can_status_bits()) & ~0x3U) | nmt_bits);
  }
  if (od->contains(0x6503, 0)) (void)od->set_u16(0x6503, 0, alarms);
  if (od->contains(0x6505, 0)) (void)od->set_u16(0x6505, 0, warnings);
  // CiA 301 0x1001 bit 4 "communication error": a lost life guard, or the
  // controller error passive or bus-off; always with the generic bit 0.
  const bool communication = life_guarding_lost || can_state != CanControllerState::error_active;
  std::uint8_t reg = 0;
  if (faults != 0 || over_range_latched || under_range_latched) reg |= 0x01;
  if ((faults & (fault_bit(FaultKind::voltage_high) | fault_bit(FaultKind::voltage_low))) != 0) reg |= 0x04;
  if ((faults & (fault_bit(FaultKind::temperature_high) | fault_bit(FaultKind::temperature_low))) != 0) reg |= 0x08;
  if (communication) reg |= 0x11;
  emcy.set_error_register(reg);
}

}  // namespace cobridge::sim
