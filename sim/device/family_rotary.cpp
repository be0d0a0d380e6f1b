// Novotechnik rotary sensors (manual J): RFC-4800, RSA-3200, RFE-3200,
// RSX-7900, RFX-6900, 1 or 2 channels. What J adds to the shared runtime:
// position objects 0x6020/ch, preset 0x6010/ch, the 0x6001/0x6002 coupling,
// EMCY 0x5000/0x9080/0x9090 as J§1.8.1 prints them, error position 0x7FF0
// with speed 0 (J§1.8), 0x6503 alarms (J§1.9.2).
#include <algorithm>

#include "canopen/emcy.hpp"
#include "families/novotechnik.hpp"
#include "families/novotechnik_rotary.hpp"
#include "device/sim_device_impl.hpp"
#include "device/storage.hpp"

namespace cobridge::sim {

namespace fam = cobridge::families;

namespace {

constexpr std::uint32_t kPositionFaults = fault_bit(FaultKind::measurement_error) |
                                          fault_bit(FaultKind::over_range) | fault_bit(FaultKind::under_range) |
                                          fault_bit(FaultKind::hardware_fault);

// J§1.8.1 0x5000 "sensor error": register 1, bytes 3-4 = 1, bytes 5-6 = 1.
constexpr canopen::Emcy kSensorError{0x5000, 1, {0x01, 0x00, 0x01, 0x00, 0x00}};

[[maybe_unused]] std::int16_t saturate16(std::int32_t v) noexcept {
  return static_cast<std::int16_t>(std::clamp<std::int32_t>(v, -32768, 32767));
}

}  // namespace

void SimDevice::Impl::rotary_factory() {
  factory[NvImage::key(0x2000, 0)] = factory_node;
  factory[NvImage::key(0x2001, 0)] = factory_kbit;
  revision = 0x00010003;  // J§1.2.1 example "65539"
  factory[NvImage::key(0x1018, 3)] = revision;
  factory[NvImage::key(0x6507, 0)] = 0x01020302;
}

void SimDevice::Impl::rotary_adjust(canopen::EntryDef& def) const { (void)def; }

std::uint32_t SimDevice::Impl::novotechnik_scaling_write(const canopen::WriteRequest& req) {
  using namespace canopen::od_abort;
  // J§1.4.2, E§5.4: writable only while scaling is on (per the family's
  // polarity of 0x6000 bit 2); only reductions of the physical resolution.
  if (!scaling_active()) return kCannotStoreDeviceState;
  const std::uint64_t v = req.as_unsigned();
  const std::uint64_t per_rev = od->get_raw(0x6501, 0).value_or(0);
  const std::uint64_t turns = od->get_raw(0x6502, 0).value_or(1);
  if (v == 0) return kValueRangeExceeded;
  if (req.index == 0x6001 && v > per_rev) return kValueRangeExceeded;
  if (req.index == 0x6002 && (v > per_rev * turns || v < turns)) return kValueRangeExceeded;
  return 0;
}

void SimDevice::Impl::novotechnik_scaling_after(std::uint16_t index) {
  // J§1.4.2, E§5.4, E§5.5: total = per revolution x distinguishable turns.
  const std::uint64_t turns = std::max<std::uint64_t>(od->get_raw(0x6502, 0).value_or(1), 1);
  if (index == 0x6001) {
    (void)od->set_u32(0x6002, 0, static_cast<std::uint32_t>(od->get_raw(0x6001, 0).value_or(0) * turns));
  } else if (index == 0x6002) {
    (void)od->set_u32(0x6001, 0, static_cast<std::uint32_t>(od->get_raw(0x6002, 0).value_or(0) / turns));
  }
}

std::uint32_t SimDevice::Impl::rotary_on_write(const canopen::WriteRequest& req) {
  using namespace canopen::od_abort;
  switch (req.index) {
    case 0x6300:
      // J§1.3.2 prints the CAM state rw; it is a state register (E, CiA 406).
      return req.sub >= 1 ? kWriteOfReadOnly : 0;
    case 0x6001:
    case 0x6002:
      return novotechnik_scaling_write(req);
    case 0x6010:
      return req.sub >= 1 ? encoder.check_preset(req.sub - 1, req.as_signed()) : 0;
    case 0x2001: {
      const std::uint64_t v = req.as_unsigned();  // ordering-code rates (J§1.2.2)
      return v == 50 || v == 125 || v == 250 || v == 500 || v == 800 || v == 1000 ? 0 : kValueRangeExceeded;
    }
    default:
      return 0;
  }
}

void SimDevice::Impl::rotary_after_write(std::uint16_t index, std::uint8_t sub) {
  if (index == 0x6001 || index == 0x6002) novotechnik_scaling_after(index);
  if (index >= 0x6000) configure_encoder();
  if (index == 0x6010 && sub >= 1 && sub <= channels) encoder.preset(sub - 1, get_int(0x6010, sub));
}

void SimDevice::Impl::rotary_publish(std::size_t ch, ChannelSample& s, const ChannelSample& before, bool first) {
  const auto sub = static_cast<std::uint8_t>(ch + 1);
  // J§1.8: on a sensor error the pipeline reports 0x7FF0 and speed 0.
  (void)od->set_i32(0x6020, sub, static_cast<std::int32_t>(s.position_bits));
  (void)od->set_i16(0x6030, sub, saturate16(s.speed));
  (void)od->set_u8(0x6300, sub, s.cams);
  (void)od->set_u8(0x6400, sub, s.work_area);
  if (first) return;
  if (s.cams != before.cams) {
    const auto changed = static_cast<std::uint16_t>(s.cams ^ before.cams);
    send_emcy(canopen::Emcy{fam::kNovotechnikCamEmcy, 1, fam::rotary_cam_emcy_bytes(sub, changed, s.cams)},
              fam::EmcyLevel::unspecified);
  }
  if (s.work_area != before.work_area)
    send_emcy(canopen::Emcy{fam::kNovotechnikWorkAreaEmcy, 1, fam::rotary_work_area_emcy_bytes(sub, s.work_area)},
              fam::EmcyLevel::unspecified);
}

void SimDevice::Impl::rotary_fault(FaultKind fault, TimePoint now) {
  (void)now;
  switch (fault) {
    case FaultKind::measurement_error:
    case FaultKind::over_range:
    case FaultKind::under_range:
    case FaultKind::hardware_fault:
      if ((faults & fault_bit(fault)) == 0) {
        const bool was_active = faults != 0;
        faults |= fault_bit(fault);
        encoder.set_measurement_error(true);
        if (!was_active) send_emcy(kSensorError, fam::EmcyLevel::unspecified);
      }
      return;
    case FaultKind::channel_disagreement:
      // J§1.9.2 alarm bit 0 exists on 2-channel sensors only.
      if (channels < 2 || (faults & fault_bit(fault)) != 0) return;
      if (faults == 0) send_emcy(kSensorError, fam::EmcyLevel::unspecified);
      faults |= fault_bit(fault);
      return;
    case FaultKind::clear:
      if (faults == 0) return;
      faults = 0;
      encoder.set_measurement_error(false);
      // J§1.8.1: when the internal error bit returns to 0, EMCY 0x0000.
      send_emcy(canopen::Emcy{}, fam::EmcyLevel::unspecified);
      return;
    default:
      return;  // J has no temperature or supply-voltage diagnostics
  }
}

void SimDevice::Impl::rotary_status() noexcept {
  alarms = 0;
  if ((faults & kPositionFaults) != 0) alarms |= 0x1000;                       // J§1.9.2 bit 12
  if ((faults & fault_bit(FaultKind::channel_disagreement)) != 0) alarms |= 0x0001;  // bit 0
  warnings = 0;
  status = 0;
}

}  // namespace cobridge::sim
