// Node-ID and bit rate: as the family's objects encode them (J§1.3.3, E§4.3
// 0x2000/0x2001; F§7.4 0x3000/0x3001), and as the LSS slave configures,
// stores and identifies them (J§1.5, E§6, F§6.3.6).
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

std::optional<std::uint8_t> lss_index_for_kbit(std::uint16_t kbit) noexcept {
  for (std::uint8_t i = 0; i <= 8; ++i)
    if (canopen::lss_bit_rate_kbit(i) == kbit && kbit != 0) return i;
  return std::nullopt;
}

std::uint16_t ifm_kbit(std::uint8_t index) noexcept {
  const auto& rates = families::kIfmBitRates;  // F§7.4 0x3001
  return index < rates.size() ? rates[index] : 0;
}

std::optional<std::uint8_t> ifm_index_for_kbit(std::uint16_t kbit) noexcept {
  for (std::uint8_t i = 0; i < 8; ++i)
    if (ifm_kbit(i) == kbit) return i;
  return std::nullopt;
}

// The node-ID object's value for `node` and back (F§7.4: ifm holds node-ID - 1,
// keeping FFh, unconfigured, as FFh; Novotechnik the node-ID itself).
std::uint8_t node_value(const families::Addressing& a, std::uint8_t node) noexcept {
  return node == cob::kNodeIdUnconfigured ? node : static_cast<std::uint8_t>(node - a.node_id_offset);
}

std::uint8_t node_of_value(const families::Addressing& a, std::uint64_t raw) noexcept {
  if (a.node_id_offset == 0) return static_cast<std::uint8_t>(raw);
  return raw >= 0x7F ? cob::kNodeIdUnconfigured : static_cast<std::uint8_t>(raw + a.node_id_offset);
}

// The bit-rate object's value for `kbit` (F§7.4 0x3001: an index into the
// family's table; J§1.3.3, E§4.3 0x2001: kbit/s), and back.
std::optional<std::uint64_t> bitrate_value(const families::Addressing& a, std::uint16_t kbit) noexcept {
  if (!a.bitrate_is_table_index) return kbit;
  for (std::size_t i = 0; i < a.bitrates.size(); ++i)
    if (a.bitrates[i] == kbit) return i;
  return std::nullopt;
}

std::uint16_t kbit_of_value(const families::Addressing& a, std::uint64_t raw) noexcept {
  if (!a.bitrate_is_table_index) return static_cast<std::uint16_t>(raw);
  return raw < a.bitrates.size() ? a.bitrates[raw] : 0;
}

canopen::LssSlaveFeatures lss_features(const DeviceSpec& spec, FamilyId family) {
  LssProfile p = spec.lss;
  // A family whose LSS predates CiA 305 V2 (J§1 intro: DSP-305 V1.1.2) has no Fastscan.
  if (p == LssProfile::family_default) p = family_facts(family).lss_fastscan ? LssProfile::v3 : LssProfile::v1;
  canopen::LssSlaveFeatures f =
      p == LssProfile::v1 ? canopen::LssSlaveFeatures::rotary_j() : canopen::LssSlaveFeatures::multiturn_e();
  if (!spec.lss_fastscan) f.fastscan = false;
  f.node_id_assignment = spec.assign;
  f.lose_node_id_requests = spec.lose_configure;
  f.bit_timings = families::traits(family).lss_bit_timings;
  return f;
}

std::uint8_t SimDevice::Impl::node_from_od() const noexcept {
  const auto& a = family_facts(family).addressing;
  return node_of_value(a, od->get_u8(a.node_id_index, 0).value_or(node_value(a, factory_node)));
}

std::uint16_t SimDevice::Impl::kbit_from_od() const noexcept {
  const auto& a = family_facts(family).addressing;
  const auto raw = od->get_raw(a.bitrate_index, 0);
  return raw ? kbit_of_value(a, *raw) : factory_kbit;
}

void SimDevice::Impl::node_to_od(std::uint8_t node) noexcept {
  const auto& a = family_facts(family).addressing;
  (void)od->set_u8(a.node_id_index, 0, node_value(a, node));
}

void SimDevice::Impl::kbit_to_od(std::uint16_t kbit) noexcept {
  const auto& a = family_facts(family).addressing;
  if (const auto v = bitrate_value(a, kbit)) (void)set_raw(*od, a.bitrate_index, 0, *v);
}

canopen::LssAddress SimDevice::Impl::identity_of() const noexcept {
  canopen::LssAddress a;
  a.vendor = spec.vendor.value_or(model.vendor);
  a.product = spec.product.value_or(model.product);
  a.revision = spec.revision.value_or(revision);
  a.serial = spec.serial;
  return a;
}

canopen::LssStoreError SimDevice::Impl::lss_store(const canopen::LssSlave& s) {
  // J§1.5.3, E§6.3: store configuration persists node-ID and bit rate.
  const std::uint8_t node = s.pending_node_id();
  const auto& a = family_facts(family).addressing;
  nv_data.params.set(a.node_id_index, 0, node_value(a, node));
  if (const auto bt = s.pending_bit_timing()) {
    const std::uint16_t kbit = canopen::lss_bit_rate_kbit(*bt);
    if (const auto v = bitrate_value(a, kbit)) nv_data.params.set(a.bitrate_index, 0, *v);
  }
  return persist() ? canopen::LssStoreError::kMediaAccess : canopen::LssStoreError::kOk;
}

void SimDevice::Impl::sync_lss_pending() {
  if (!lss) return;
  if (lss->pending_node_id() != pending_node) {
    pending_node = lss->pending_node_id();
    node_to_od(pending_node);
  }
  if (const auto bt = lss->pending_bit_timing()) {
    const std::uint16_t kbit = canopen::lss_bit_rate_kbit(*bt);
    if (kbit != 0 && kbit != pending_kbit) {
      pending_kbit = kbit;
      kbit_to_od(kbit);
    }
  }
}

}  // namespace cobridge::sim
