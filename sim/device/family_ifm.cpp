// ifm RM8xxx / RM9xxx (manual F). What F adds: node-ID object 0x3000 =
// node-ID - 1 and bit-rate index 0x3001 (F§7.4), the manufacturer twins of
// the CiA 406 objects (0x2000 position, 0x2100 <-> 0x6000 bit 0, 0x2101..
// 0x2103 <-> 0x6001..0x6003, 0x2104/0x2105 <-> 0x6401/0x6402), the event
// timer known by three names (0x1800/5 = 0x6200, mirrored read-only in
// 0x2200; F§7.3, F§7.5 0x6200), limit-switch bits 30/31 in the position (F§7.4),
// save-with-reset 0x2300, the bootloader object 0x4000 that refuses every
// value, the error history 0x1003 (F§4). F documents no EMCY codes: the
// CiA 301 classes are used and flagged "(ext)" in docs/devices.md.
#include <algorithm>

#include "canopen/emcy.hpp"
#include "device/sim_device_impl.hpp"
#include "device/storage.hpp"

namespace cobridge::sim {

namespace {

using canopen::Emcy;
using families::EmcyLevel;

// RM9000: 12-bit single-turn x 12-bit multiturn, the 2^24 total of the
// 0x2102 default (F§7.4); RM8000 single-turn.
constexpr std::uint32_t kIfmStepsPerTurn = 4096;

}  // namespace

void SimDevice::Impl::ifm_factory() {
  const bool multiturn = model.name != "RM8000";
  const std::uint32_t turns = multiturn ? 4096 : 1;
  const std::uint32_t total = kIfmStepsPerTurn * turns;
  factory[NvImage::key(0x3000, 0)] =
      factory_node == 0xFF ? 0xFFU : static_cast<std::uint8_t>(factory_node - 1U);  // F§7.4 "add 1"
  factory[NvImage::key(0x3001, 0)] = ifm_index_for_kbit(factory_kbit).value_or(3);
  factory[NvImage::key(0x1000, 0)] = multiturn ? 0x00020196 : 0x00010196;  // (ext) CiA 406 device types
  revision = 0x00010000;
  factory[NvImage::key(0x6501, 0)] = kIfmStepsPerTurn;
  factory[NvImage::key(0x6502, 0)] = turns;
  factory[NvImage::key(0x6001, 0)] = kIfmStepsPerTurn;
  factory[NvImage::key(0x6002, 0)] = total;
  factory[NvImage::key(0x2101, 0)] = kIfmStepsPerTurn;
  factory[NvImage::key(0x2102, 0)] = total;
  factory[NvImage::key(0x650A, 2)] = 0;
  factory[NvImage::key(0x650A, 3)] = total - 1U;
  factory[NvImage::key(0x6402, 1)] = 0;
  factory[NvImage::key(0x6507, 0)] = 0x01000302;
  factory[NvImage::key(0x6000, 0)] = 0;  // shared with 0x2100 bit 0, CW (F§7.4 0x2100)
  factory[NvImage::key(0x6301, 1)] = 0;
  // Mapping F leaves open (F§7.3): the position alone.
  factory[NvImage::key(0x1A00, 0)] = 1;
  factory[NvImage::key(0x1A00, 1)] = 0x60040020;
  factory[NvImage::key(0x1A01, 0)] = 1;
  factory[NvImage::key(0x1A01, 1)] = 0x60040020;
}

void SimDevice::Impl::ifm_adjust(canopen::EntryDef& def) const {
  // F§4 says the mapping is dynamic, F§7.3 prints its count ro (B.9.8).
  if ((def.index == 0x1A00 || def.index == 0x1A01) && def.sub == 0) def.access = canopen::Access::kRw;
}

std::uint32_t SimDevice::Impl::ifm_on_write(const canopen::WriteRequest& req) {
  using namespace canopen::od_abort;
  const std::uint64_t v = req.as_unsigned();
  const std::uint64_t per_rev = od->get_raw(0x6501, 0).value_or(kIfmStepsPerTurn);
  const std::uint64_t total = per_rev * od->get_raw(0x6502, 0).value_or(1);
  switch (req.index) {
    case 0x1003:
      return req.sub == 0 && v == 0 ? 0 : kValueRangeExceeded;  // F§7.3: write 0 to clear
    case 0x2300:
      // F§6.3.4: save, then reset. The SDO confirmation goes out first.
      if (v != kIfmSaveWithReset) return kValueRangeExceeded;
      if (!pre_operational()) return kCannotStoreDeviceState;
      if (const std::uint32_t r = save(1)) return r;
      reset_node_requested = true;
      return 0;
    case 0x4000:
      return kValueRangeExceeded;  // the bootloader code is not published (F§7.4)
    case 0x6001:
    case 0x2101:
      return v == 0 || v > per_rev ? kValueRangeExceeded : 0;  // "not transferred"
    case 0x6002:
    case 0x2102:
      return v == 0 || v > total ? kValueRangeExceeded : 0;
    case 0x6003:
    case 0x2103:
      return encoder.check_preset(0, static_cast<std::int64_t>(v));
    case 0x2104:
    case 0x2105:
      return v >= total ? kValueRangeExceeded : 0;
    default:
      return 0;
  }
}

void SimDevice::Impl::ifm_after_write(std::uint16_t index, std::uint8_t sub) {
  auto copy32 = [this](std::uint16_t from, std::uint8_t fsub, std::uint16_t to, std::uint8_t tsub) {
    (void)set_raw(*od, to, tsub, od->get_raw(from, fsub).value_or(0));
  };
  switch (index) {
    case 0x6001: copy32(0x6001, 0, 0x2101, 0); break;
    case 0x2101: copy32(0x2101, 0, 0x6001, 0); break;
    case 0x6002: copy32(0x6002, 0, 0x2102, 0); break;
    case 0x2102: copy32(0x2102, 0, 0x6002, 0); break;
    case 0x6003: copy32(0x6003, 0, 0x2103, 0); break;
    case 0x2103: copy32(0x2103, 0, 0x6003, 0); break;
    case 0x6401: copy32(0x6401, 1, 0x2104, 0); break;
    case 0x2104: copy32(0x2104, 0, 0x6401, 1); break;
    case 0x6402: copy32(0x6402, 1, 0x2105, 0); break;
    case 0x2105: copy32(0x2105, 0, 0x6402, 1); break;
    case 0x6000: {
      const std::uint64_t bit = od->get_raw(0x6000, 0).value_or(0) & 1U;
      (void)od->set_u16(0x2100, 0, static_cast<std::uint16_t>((od->get_u16(0x2100, 0).value_or(0) & ~1U) | bit));
      break;
    }
    case 0x2100: {
      const std::uint64_t bit = od->get_raw(0x2100, 0).value_or(0) & 1U;
      (void)od->set_u16(0x6000, 0, static_cast<std::uint16_t>((od->get_u16(0x6000, 0).value_or(0) & ~1U) | bit));
      break;
    }
    case 0x6200: {
      const std::uint16_t ms = od->get_u16(0x6200, 0).value_or(100);
      (void)od->set_u32(0x1800, 5, ms);
      (void)od->set_u16(0x2200, 0, ms);
      reconfigure_tpdo(0, now_cache);
      break;
    }
    case 0x1800:
      if (sub == 5) ifm_mirror_event_timer();
      break;
    case 0x1003:
      for (std::uint8_t s = 1; s <= 10; ++s) (void)od->set_u32(0x1003, s, 0);
      break;
    case 0x3000:
    case 0x3001:
      pending_node = node_from_od();
      pending_kbit = kbit_from_od();
      break;
    default:
      break;
  }
  if (index == 0x6003 || index == 0x2103)
    encoder.preset(0, static_cast<std::int64_t>(od->get_raw(0x6003, 0).value_or(0)));
  configure_encoder();
}

void SimDevice::Impl::ifm_mirror_event_timer() noexcept {
  // F§7.3, F§7.5 0x6200: one event timer, three objects. 0x2200 is read-only, so no
  // parameter load reaches it; 0x6200 has no 0 (its low limit is 1).
  const auto ms = static_cast<std::uint16_t>(std::min<std::uint64_t>(od->get_raw(0x1800, 5).value_or(0), 0xFFFF));
  if (ms != 0) (void)od->set_u16(0x6200, 0, ms);
  (void)od->set_u16(0x2200, 0, ms);
}

void SimDevice::Impl::ifm_publish(ChannelSample& s, const ChannelSample& before, bool first) {
  (void)before;
  (void)first;
  // The pipeline adds the limit-switch bits 30/31 (F§7.4 0x2104/0x2105).
  (void)od->set_u32(0x6004, 0, s.position_bits);
  (void)od->set_u32(0x2000, 0, s.position_bits);
  (void)od->set_i16(0x6030, 1, static_cast<std::int16_t>(std::clamp<std::int32_t>(s.speed, -32768, 32767)));
  const std::int32_t magnitude = s.speed32 < 0 ? -s.speed32 : s.speed32;
  (void)od->set_u8(0x3011, 0, static_cast<std::uint8_t>(std::clamp<std::int32_t>(magnitude, 0, 255)));
  (void)od->set_u8(0x6300, 1, s.cams);
  (void)od->set_u8(0x6400, 1, s.work_area);
  (void)od->set_i32(0x6509, 0, static_cast<std::int32_t>(encoder.offset(0)));
}

void SimDevice::Impl::ifm_fault(FaultKind fault, TimePoint now) {
  (void)now;
  if (fault == FaultKind::clear) {
    if (faults == 0) return;
    faults = 0;
    refresh_status();
    send_emcy(Emcy{}, EmcyLevel::unspecified);
    return;
  }
  if (fault == FaultKind::channel_disagreement || (faults & fault_bit(fault)) != 0) return;
  faults |= fault_bit(fault);
  refresh_status();
  // (ext) CiA 301 classes; F has no table (F§4).
  std::uint16_t code = canopen::emcy_code::kDeviceHardware;
  if (fault == FaultKind::temperature_high || fault == FaultKind::temperature_low)
    code = canopen::emcy_code::kDeviceTemperature;
  if (fault == FaultKind::voltage_high || fault == FaultKind::voltage_low) code = canopen::emcy_code::kSupplyVoltage;
  send_emcy(Emcy{code, emcy.error_register(), {0, 0, 0, 0, 0}}, EmcyLevel::unspecified);
}

void SimDevice::Impl::ifm_life_guarding(bool lost) {
  if (!lost) return;
  refresh_status();
  // (ext) CiA 301 0x8130 "life guard error"; reaction per 0x1029/1.
  send_emcy(Emcy{canopen::emcy_code::kLifeGuardHeartbeat, emcy.error_register(), {0, 0, 0, 0, 0}},
            EmcyLevel::unspecified);
  const auto t = nmt.apply_error_behaviour(od->get_u8(0x1029, 1).value_or(0));
  if (t.outcome == canopen::NmtOutcome::state_changed) on_nmt_change(t.from, now_cache);
}

}  // namespace cobridge::sim
