// The simulated device's CAN controller: how it reacts to the bus state
// the simulator announces with Linux CAN error frames (control `bus-error`,
// sim/app/bus_fault.hpp). The simulator's buses are vcan, which never
// has errors, so the error frame stands for what every controller on the
// real bus would have seen; each device goes through the CiA 301 fault
// confinement states and reports them the way its manual says:
//
//   error passive  EMCY 0x8120, 0x1002 bit 4 (J§1.9.1) / bit 16 (E§10.1)
//   bus-off        silent: no RX, no TX (timers go on, frames are lost);
//                  0x1002 bits 3+2 (J) / 17+18 (E): bus-off, bus-off timer started
//   recovered      EMCY 0x8140 "recovered from bus-off", bits cleared
//
// The EMCY bytes are the J§1.8.1, E§9.1 rows; ifm (F) documents no codes,
// so it sends the CiA 301 ones with its error register, marked (ext) in
// docs/devices.md. Leaving error passive has no row in either table and no
// EMCY here; it clears the status bit.
// Thread: the device's (the simulator's bus thread).
#include <linux/can/error.h>

#include "canopen/emcy.hpp"
#include "device/sim_device_impl.hpp"

namespace cobridge::sim {

void SimDevice::Impl::on_error_frame(const can::Frame& frame, TimePoint now) {
  now_cache = now;
  const std::uint32_t cls = frame.id;
  if ((cls & CAN_ERR_BUSOFF) != 0) {
    enter_bus_off();
    return;
  }
  if ((cls & CAN_ERR_RESTARTED) != 0) {
    // The controller was restarted after bus-off (Linux: restart-ms or
    // `ip link set ... type can restart`): error active again.
    recover_from_bus_off();
    return;
  }
  if ((cls & CAN_ERR_CRTL) == 0 || frame.len < 2) return;
  const std::uint8_t crtl = frame.data[1];
  if ((crtl & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) != 0) {
    enter_error_passive();
  } else if ((crtl & CAN_ERR_CRTL_ACTIVE) != 0) {
    if (can_state == CanControllerState::bus_off) {
      recover_from_bus_off();
    } else {
      leave_error_passive();
    }
  }
  // Error warning (counters >= 96) changes nothing a manual documents.
}

void SimDevice::Impl::enter_error_passive() {
  if (can_state != CanControllerState::error_active) return;
  can_state = CanControllerState::error_passive;
  refresh_status();
  // An error-passive node still transmits, so the EMCY reaches the bus.
  send_can_emcy(canopen::emcy_code::kCanErrorPassive);
}

void SimDevice::Impl::leave_error_passive() {
  if (can_state != CanControllerState::error_passive) return;
  can_state = CanControllerState::error_active;
  refresh_status();
}

void SimDevice::Impl::enter_bus_off() {
  if (can_state == CanControllerState::bus_off) return;
  can_state = CanControllerState::bus_off;
  refresh_status();
}

void SimDevice::Impl::recover_from_bus_off() {
  if (can_state != CanControllerState::bus_off) return;
  can_state = CanControllerState::error_active;  // the restart clears the error counters
  refresh_status();
  send_can_emcy(canopen::emcy_code::kBusOffRecovered);
}

std::uint32_t SimDevice::Impl::can_status_bits() const noexcept {
  unsigned passive = 0;
  unsigned bus_off = 0;
  unsigned timer = 0;
  switch (family) {
    case FamilyId::novotechnik_rotary: passive = 4; bus_off = 3; timer = 2; break;      // J§1.9.1
    case FamilyId::novotechnik_multiturn: passive = 16; bus_off = 17; timer = 18; break;  // E§10.1
    case FamilyId::ifm_rm: return 0;                                                     // F: no 0x1002
  }
  switch (can_state) {
    case CanControllerState::error_active: return 0;
    case CanControllerState::error_passive: return 1U << passive;
    // The device restarts its controller by itself after bus-off; the timer
    // runs from the moment it went bus-off (the restart itself is what the
    // simulator's `restarted` / `error-active` frame announces).
    case CanControllerState::bus_off: return (1U << bus_off) | (1U << timer);
  }
  return 0;
}

void SimDevice::Impl::send_can_emcy(std::uint16_t code) {
  switch (family) {
    case FamilyId::novotechnik_rotary:
      // J§1.8.1: register byte 1, bytes 3-7 zero.
      send_emcy(canopen::Emcy{code, 1, {0, 0, 0, 0, 0}}, families::EmcyLevel::unspecified);
      return;
    case FamilyId::novotechnik_multiturn:
      // E§9.1: byte 2 is 0 in both rows, level Hard (never filtered by 0x2104).
      send_emcy(canopen::Emcy{code, 0, {0, 0, 0, 0, 0}}, families::EmcyLevel::hard);
      return;
    case FamilyId::ifm_rm:
      // (ext) CiA 301 code with the device's error register (F§4).
      send_emcy(canopen::Emcy{code, emcy.error_register(), {0, 0, 0, 0, 0}}, families::EmcyLevel::unspecified);
      return;
  }
}

}  // namespace cobridge::sim
