// The SDO write rules every family shares: the storage signatures, the TPDO
// communication and mapping records (CiA 301 §7.5.2.35-36 with the
// manuals' limits), and what a written object changes afterwards.
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

std::uint32_t SimDevice::Impl::on_read(std::uint16_t index, std::uint8_t sub) {
  (void)index;
  (void)sub;
  return 0;
}

std::uint32_t SimDevice::Impl::on_write(const canopen::WriteRequest& req) {
  using namespace canopen::od_abort;
  const std::uint32_t value = static_cast<std::uint32_t>(req.as_unsigned());
  if ((req.index == kStore || req.index == kRestore) && req.sub >= 1) {
    // J§1.10, E§11 (and F§6.1.1 for ifm): signatures only in pre-operational.
    if (!pre_operational()) return kCannotStoreDeviceState;
    const std::uint8_t subs = traits.store_subs;
    if (req.index == kStore) {
      if (value == kSignatureSave) return req.sub <= subs ? save(req.sub) : 0;  // sub 5: "do not use", no-op
      if (value == kSignatureKill && traits.kill_signature && req.sub <= subs) return kill(req.sub);
      return kCannotStore;
    }
    if (value == kSignatureLoad && req.sub <= subs) {
      const std::uint32_t r = load(req.sub);
      if (r == 0) {
        pending_node = node_from_od();
        pending_kbit = kbit_from_od();
      }
      return r;
    }
    return kCannotStore;
  }
  if (req.index == kTpdoComm || req.index == kTpdoComm + 1) return check_tpdo_write(req);
  if (req.index == kTpdoMap || req.index == kTpdoMap + 1) return check_mapping_write(req);
  return family_on_write(req);
}

void SimDevice::Impl::after_write(std::uint16_t index, std::uint8_t sub) {
  const TimePoint now = now_cache;
  if ((index == kStore || index == kRestore) && sub >= 1) {
    // The signature objects read back as the manual prints them (0; J§1.3.1).
    (void)od->set_u32(index, sub, 0);
    if (index == kRestore || index == kStore) {
      configure_encoder();
      if (traits.condition_monitoring) condition_configure();
      for (std::size_t i = 0; i < 2; ++i) reconfigure_tpdo(i, now);
      configure_guard();
      restart_heartbeat(now);
    }
    return;
  }
  switch (index) {
    case kTpdoComm: case kTpdoComm + 1: case kTpdoMap: case kTpdoMap + 1:
      family_after_write(index, sub);  // ifm mirrors 0x1800/5 into 0x6200 / 0x2200
      reconfigure_tpdo(index & 1U, now);
      return;
    case kHeartbeatTime: restart_heartbeat(now); return;
    case kGuardTime: case kLifeTimeFactor: configure_guard(); return;
    case kNmtStartup: nmt.set_autostart((od->get_u32(kNmtStartup, 0).value_or(0) & kAutostartBit) != 0); return;
    default: break;
  }
  if (is_address_object(index) && traits.address_activation == families::AddressActivation::last_written) {
    // J§1.3.3, E§4.3: the written node-ID / bit rate is pending until a reset.
    pending_node = node_from_od();
    pending_kbit = kbit_from_od();
    return;
  }
  family_after_write(index, sub);
  if ((index >= 0x6000 && index < 0x7000) || index == 0x2010 || index == 0x3010) configure_encoder();
  if (traits.condition_monitoring && index >= 0x2300 && index < 0x2400) condition_configure();
}

std::uint32_t SimDevice::Impl::check_tpdo_write(const canopen::WriteRequest& req) {
  using namespace canopen::od_abort;
  const std::size_t i = req.index & 1U;
  const std::uint32_t v = static_cast<std::uint32_t>(req.as_unsigned());
  const std::uint32_t current = od->get_u32(req.index, 1).value_or(Tpdo::kInvalid);
  if (req.sub == 1) {
    // CiA 301 §7.5.2.35: 29-bit identifiers are not supported here, and the
    // identifier of a valid PDO cannot change (disable it first).
    if ((v & 0x20000000u) != 0 || (v & 0x1FFFF800u) != 0) return kValueRangeExceeded;
    const bool was_valid = (current & Tpdo::kInvalid) == 0;
    const bool stays_valid = (v & Tpdo::kInvalid) == 0;
    if (was_valid && stays_valid && (v & 0x7FFu) != (current & 0x7FFu)) return kValueRangeExceeded;
    if (stays_valid && !layout_ok[i] && od->get_u8(kTpdoMap + static_cast<std::uint16_t>(i), 0).value_or(0) != 0)
      return kCannotStoreDeviceState;
    return 0;
  }
  if (req.sub == 2) {
    // J§1.3.1, E§4.1, F§7.3 transmission-type tables.
    const bool sync = v <= 240;
    const bool async = !(i == 1 && traits.tpdo2_sync_only);
    const bool event = async && (v == 254 || v == 255);
    const bool rtr = async && traits.rtr_transmission && (v == 252 || v == 253);
    return sync || event || rtr ? 0 : kValueRangeExceeded;
  }
  return family_on_write(req);
}

std::uint32_t SimDevice::Impl::check_mapping_write(const canopen::WriteRequest& req) {
  using namespace canopen::od_abort;
  const std::size_t i = req.index & 1U;
  const auto comm = static_cast<std::uint16_t>(kTpdoComm + i);
  // J§1.7.2 step 1 / E§8.2 step 1: the PDO must be disabled (bit 31); the
  // manuals list only 0x08000022 for a refusal of this kind. E also wants
  // pre-operational.
  if ((od->get_u32(comm, 1).value_or(0) & Tpdo::kInvalid) == 0) return kCannotStoreDeviceState;
  if (traits.mapping_needs_pre_operational && !pre_operational()) return kCannotStoreDeviceState;
  const std::size_t max_entries = traits.max_mapped_objects;
  if (req.sub == 0) {
    const std::uint64_t n = req.as_unsigned();
    if (n > max_entries) return 0x06040042;  // CiA 301: number / length of mapped objects exceeded
    std::array<std::uint32_t, 8> entries{};
    for (std::size_t k = 0; k < n; ++k)
      entries[k] = od->get_u32(req.index, static_cast<std::uint8_t>(k + 1)).value_or(0);
    const auto result = canopen::build_pdo_layout(std::span<const std::uint32_t>(entries.data(), n), {},
                                                  canopen::PdoLimits{max_entries, 64});
    if (!result.ok()) return canopen::sdo_abort_code(static_cast<canopen::PdoMapErrc>(result.error.value()));
    for (std::size_t k = 0; k < n; ++k)
      if (entries[k] == 0) return 0x06040041;
    return 0;
  }
  // CiA 301 §7.5.2.36 step 2: entries change only while sub 0 is 0.
  if (od->get_u8(req.index, 0).value_or(0) != 0) return kCannotStoreDeviceState;
  const std::uint32_t raw = static_cast<std::uint32_t>(req.as_unsigned());
  if (raw == 0) return 0;
  const auto e = canopen::PdoMapEntry::from_raw(raw);
  const auto info = od->info(e.index, e.sub);
  if (!info || !info->pdo_mappable || info->is_string || info->size * 8U != e.bits) return 0x06040041;
  return 0;
}

}  // namespace cobridge::sim
