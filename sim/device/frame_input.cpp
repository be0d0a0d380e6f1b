// What the device does with a received frame (NMT, LSS, SYNC, RTR, SDO,
// CAN error frames) and with the passing of time (measuring cycle,
// heartbeat, TPDO timers, held answers).
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

void SimDevice::Impl::on_frame(const can::Frame& frame, TimePoint now) {
  if (!powered || silent) return;
  if (frame.is_error()) {
    on_error_frame(frame, now);
    return;
  }
  if (frame.is_extended() || can_state == CanControllerState::bus_off) return;
  now_cache = now;
  const bool configured = cob::valid_node_id(active_node);
  if (frame.id == canopen::cob::kNmt) {
    if (configured) on_nmt_frame(frame, now);
    return;
  }
  if (frame.id == canopen::cob::kLssMasterToSlave) {
    on_lss_frame(frame, now);
    return;
  }
  if (!configured) return;
  if (reboot_on_sdo != 0 && frame.id == cob::kSdoRxBase + active_node && --reboot_on_sdo == 0) {
    power_off();
    if (power_on(now)) powered = false;  // the nv file went bad: stays off, as a real device would
    return;
  }
  const std::uint32_t sync_cob = od->get_u32(kCobIdSync, 0).value_or(canopen::cob::kSync) & 0x7FFu;
  if (frame.id == sync_cob && !frame.is_rtr()) {
    if (canopen::parse_sync(frame, sync_cob).ok() && nmt.allows(canopen::NmtService::sync)) on_sync(now);
    return;
  }
  if (frame.is_rtr()) {
    on_rtr_frame(frame, now);
    return;
  }
  if (sdo && nmt.allows(canopen::NmtService::sdo)) {
    if (sdo_fault_injected(frame)) return;
    (void)sdo->on_frame(frame, now);
    if (reset_node_requested) {
      // ifm 0x2300: the confirmation went out above, now the reset (F§6.3.4).
      reset_node_requested = false;
      reset_node(now);
    }
  }
}

bool SimDevice::Impl::sdo_fault_injected(const can::Frame& frame) noexcept {
  if ((abort_sdo_index == 0 && ignore_sdo_index == 0) || frame.id != cob::kSdoRxBase + active_node || frame.len != 8)
    return false;
  const unsigned ccs = frame.data[0] >> 5;  // 1 initiate download, 2 initiate upload (CiA 301 §7.2.4.3)
  const auto index = static_cast<std::uint16_t>(frame.data[1] | (frame.data[2] << 8));
  if (ccs != 1 && ccs != 2) return false;
  if (ignore_sdo_index != 0 && index == ignore_sdo_index) {
    if (--ignore_sdo_left == 0) ignore_sdo_index = 0;
    return true;
  }
  if (abort_sdo_index == 0 || index != abort_sdo_index) return false;
  const std::uint32_t c = abort_sdo_code;
  // CiA 301 §7.2.4.3.17: 0x80, the request's multiplexer, the code (little-endian).
  (void)send(can::Frame::make8(cob::kSdoTxBase + active_node,
                               {0x80, frame.data[1], frame.data[2], frame.data[3], static_cast<std::uint8_t>(c),
                                static_cast<std::uint8_t>(c >> 8), static_cast<std::uint8_t>(c >> 16),
                                static_cast<std::uint8_t>(c >> 24)}),
             TruthRecord::Kind::sdo);
  abort_sdo_index = 0;
  return true;
}

void SimDevice::Impl::on_nmt_frame(const can::Frame& frame, TimePoint now) {
  const bool start = frame.len >= 2 && frame.data[0] == static_cast<std::uint8_t>(canopen::NmtCommand::start) &&
                     (frame.data[1] == 0 || frame.data[1] == active_node);
  if (start && ignore_nmt_starts != 0) {
    --ignore_nmt_starts;
    return;
  }
  const canopen::NmtTransition t = nmt.on_frame(frame, active_node);
  switch (t.outcome) {
    case canopen::NmtOutcome::reset_node: reset_node(now); break;
    case canopen::NmtOutcome::reset_communication: reset_communication(now); break;
    case canopen::NmtOutcome::state_changed: on_nmt_change(t.from, now); break;
    default: break;
  }
}

void SimDevice::Impl::on_lss_frame(const can::Frame& frame, TimePoint now) {
  if (!lss) return;
  (void)lss->on_frame(frame);
  sync_lss_pending();
  if (lss->take_bit_timing_activation()) active_kbit = pending_kbit;
  if (lss->take_reset_communication_request()) reset_communication(now);
}

void SimDevice::Impl::on_sync(TimePoint now) {
  for (std::size_t i = 0; i < 2; ++i) {
    if (!tpdo_present[i]) continue;
    tpdo[i].on_sync(now);
    if (tpdo[i].sample_pending()) {
      fill_tpdo(i, sampled[i]);
      sampled_valid[i] = true;
    }
    if (nmt.allows(canopen::NmtService::pdo) && tpdo[i].due(now)) send_tpdo(i, now);
  }
}

void SimDevice::Impl::on_rtr_frame(const can::Frame& frame, TimePoint now) {
  if (frame.id == canopen::cob::kNmtErrorControlBase + active_node) {
    if (!nmt.allows(canopen::NmtService::error_control)) return;
    can::Frame reply;
    if (guard.on_frame(frame, active_node, nmt.state(), now, reply)) {
      if (life_guarding_lost) family_life_guarding(false);
      (void)send(reply, TruthRecord::Kind::guard);
    }
    return;
  }
  for (std::size_t i = 0; i < 2; ++i) {
    if (!tpdo_present[i] || frame.id != tpdo[i].can_id()) continue;
    if (tpdo[i].on_rtr(now) && nmt.allows(canopen::NmtService::pdo) && tpdo[i].due(now)) send_tpdo(i, now);
  }
}

TimePoint SimDevice::Impl::process(TimePoint now) {
  if (!powered || silent) return canopen::kNever;
  now_cache = now;
  if (now >= next_measure) {
    measure(now);
    const auto behind = (now - next_measure) / kMeasuringCycle;
    next_measure += kMeasuringCycle * (behind + 1);
  }
  if (now >= next_heartbeat && nmt.allows(canopen::NmtService::error_control)) {
    (void)send(canopen::make_heartbeat(active_node, nmt.state()), TruthRecord::Kind::heartbeat);
    const auto period = std::chrono::milliseconds(od->get_u16(kHeartbeatTime, 0).value_or(0));
    if (period.count() == 0) {
      next_heartbeat = canopen::kNever;
    } else {
      const auto behind = (now - next_heartbeat) / period;
      next_heartbeat += period * (behind + 1);
    }
  }
  TimePoint next = std::min(next_measure, next_heartbeat);
  next = std::min(next, guard.process(now));
  next = std::min(next, emcy.process(now));
  for (std::size_t i = 0; i < 2; ++i) {
    if (!tpdo_present[i]) continue;
    if (nmt.allows(canopen::NmtService::pdo) && tpdo[i].due(now)) send_tpdo(i, now);
    next = std::min(next, tpdo[i].next_deadline());
  }
  if (sdo) next = std::min(next, sdo->process(now));
  next = std::min(next, late_lss.release(now, [this](const can::Frame& f) { (void)send(f, TruthRecord::Kind::lss); }));
  return next;
}

void SimDevice::Impl::inject(FaultKind fault, TimePoint now) {
  if (!powered) return;
  now_cache = now;
  family_fault(fault, now);
  refresh_status();
}

}  // namespace cobridge::sim
