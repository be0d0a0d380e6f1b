// The simulated device's object dictionary: built from the EDS with the
// factory values the EDS leaves open, the family's corrections and the
// per-device identity, hooked to the SDO rules, and (re)loaded from the
// factory values or a stored image.
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

bool is_writable(const canopen::ObjectDictionary& od, std::uint16_t index, std::uint8_t sub) {
  const auto info = od.info(index, sub);
  return info && info->access == canopen::Access::kRw;
}

std::uint32_t set_raw(canopen::ObjectDictionary& od, std::uint16_t index, std::uint8_t sub,
                      std::uint64_t raw) noexcept {
  const auto info = od.info(index, sub);
  if (!info) return canopen::od_abort::kObjectDoesNotExist;
  using canopen::DataType;
  switch (info->type) {
    case DataType::kInteger8: return od.set_i8(index, sub, static_cast<std::int8_t>(static_cast<std::uint8_t>(raw)));
    case DataType::kInteger16:
      return od.set_i16(index, sub, static_cast<std::int16_t>(static_cast<std::uint16_t>(raw)));
    case DataType::kInteger32:
      return od.set_i32(index, sub, static_cast<std::int32_t>(static_cast<std::uint32_t>(raw)));
    case DataType::kInteger64: return od.set_i64(index, sub, static_cast<std::int64_t>(raw));
    case DataType::kReal32: return od.set_f32(index, sub, std::bit_cast<float>(static_cast<std::uint32_t>(raw)));
    default: break;
  }
  if (info->is_string) return canopen::od_abort::kLengthMismatch;
  const std::uint64_t mask = info->size >= 8 ? ~std::uint64_t{0} : (std::uint64_t{1} << (8U * info->size)) - 1U;
  return od.set_u64(index, sub, raw & mask);
}

std::int64_t SimDevice::Impl::get_int(std::uint16_t index, std::uint8_t sub) const noexcept {
  const auto info = od->info(index, sub);
  if (!info || info->is_string) return 0;
  const std::uint64_t raw = od->get_raw(index, sub).value_or(0);
  using canopen::DataType;
  switch (info->type) {
    case DataType::kInteger8: return static_cast<std::int8_t>(static_cast<std::uint8_t>(raw));
    case DataType::kInteger16: return static_cast<std::int16_t>(static_cast<std::uint16_t>(raw));
    case DataType::kInteger32: return static_cast<std::int32_t>(static_cast<std::uint32_t>(raw));
    case DataType::kInteger64: return static_cast<std::int64_t>(raw);
    default: return static_cast<std::int64_t>(raw);
  }
}

std::uint64_t SimDevice::Impl::factory_value(const device::ObjectDesc& e, std::uint8_t node) const noexcept {
  const std::uint32_t key = NvImage::key(e.index, e.sub);
  if (legacy_kill && model.legacy_rsx_rfx) {
    // J§1.10 / J§1.3.3 0x2001: RSX/RFX 'kill' also resets the custom factory
    // parameters, the bit rate to 250 kbit/s whatever the ordering code said.
    if (e.index == 0x2000 && e.sub == 0) return 0x7F;
    if (e.index == 0x2001 && e.sub == 0) return 250;
  }
  if (const auto it = factory.find(key); it != factory.end()) return it->second;
  return eds_default_raw(e, node == cob::kNodeIdUnconfigured ? 0 : node);
}

Error SimDevice::Impl::build_od() {
  canopen::ObjectDictionary::Options options;
  od = std::make_unique<canopen::ObjectDictionary>(options);
  const std::uint8_t node = active_node;
  auto adjust = [this, node](canopen::EntryDef& def) {
    // Values the EDS leaves open come from the factory table; then the
    // family may change what the manual contradicts.
    if (const auto it = factory.find(NvImage::key(def.index, def.sub)); it != factory.end()) {
      const device::ObjectDesc* e = desc.find(def.index, def.sub);
      if (e != nullptr && !is_string_type(e->data_type)) {
        const canopen::Number n = canopen::Number(it->second);
        def.value = n;
        if (device::is_signed_integer(e->data_type)) {
          const std::uint32_t w = device::bit_size(e->data_type);
          const std::uint64_t sign = std::uint64_t{1} << (w - 1U);
          const std::uint64_t v = it->second & ((w >= 64) ? ~std::uint64_t{0} : ((std::uint64_t{1} << w) - 1U));
          def.value = canopen::Number(static_cast<std::int64_t>(v ^ sign) - static_cast<std::int64_t>(sign));
        }
      }
    }
    (void)node;
    // A factory value outside the EDS limits (node-ID FFh = unconfigured in
    // 0x2000, limits 1..127) goes in through the typed setter afterwards.
    auto outside = [&def](const std::optional<canopen::Number>& lim, bool is_low) {
      if (!lim) return false;
      if (def.value.kind() == canopen::Number::Kind::kSigned || lim->kind() == canopen::Number::Kind::kSigned) {
        const std::int64_t v = def.value.kind() == canopen::Number::Kind::kSigned
                                   ? def.value.as_signed() : static_cast<std::int64_t>(def.value.as_unsigned());
        const std::int64_t l = lim->kind() == canopen::Number::Kind::kSigned
                                   ? lim->as_signed() : static_cast<std::int64_t>(lim->as_unsigned());
        return is_low ? v < l : v > l;
      }
      return is_low ? def.value.as_unsigned() < lim->as_unsigned() : def.value.as_unsigned() > lim->as_unsigned();
    };
    if (outside(def.low, true) || outside(def.high, false)) {
      if (const device::ObjectDesc* e = desc.find(def.index, def.sub); e != nullptr && def.low)
        def.value = e->default_value.kind == device::EdsValue::Kind::kNone ? *def.low
                                                                            : canopen::Number(eds_default_raw(*e, 0));
    }
    family_adjust(def);
  };
  if (Error e = build_object_dictionary(desc, node, *od, adjust)) return e;
  family_extras();
  // Identity and names: per device, not in the EDS (J§1.2.1, E§4.1, F§7.3).
  (void)od->set_u32(kIdentity, 4, spec.serial);
  if (spec.vendor) (void)od->set_u32(kIdentity, 1, *spec.vendor);
  if (spec.product) (void)od->set_u32(kIdentity, 2, *spec.product);
  if (spec.revision) (void)od->set_u32(kIdentity, 3, *spec.revision);
  if (od->contains(0x650B, 0)) (void)od->set_u32(0x650B, 0, spec.serial);
  if (od->contains(0x1008, 0)) {
    const auto current = od->get_string(0x1008, 0);
    if (!current || current->empty()) (void)od->set_string(0x1008, 0, model.name);
  }
  if (od->contains(0x1009, 0)) (void)od->set_string(0x1009, 0, traits.hardware_version);
  if (od->contains(0x100A, 0)) (void)od->set_string(0x100A, 0, traits.software_version);
  install_hooks();
  return {};
}

void SimDevice::Impl::install_hooks() {
  canopen::Hooks hooks;
  hooks.on_read = [this](std::uint16_t index, std::uint8_t sub) { return on_read(index, sub); };
  hooks.on_write = [this](const canopen::WriteRequest& req) { return on_write(req); };
  hooks.after_write = [this](std::uint16_t index, std::uint8_t sub) { after_write(index, sub); };
  std::uint16_t previous = 0;
  bool first = true;
  for (const device::ObjectDesc& e : desc.entries) {
    if (!first && e.index == previous) continue;
    first = false;
    previous = e.index;
    (void)od->set_hooks(e.index, hooks);
  }
  // The alias the default mapping names is read like the position (E§4.1).
  if (const auto alias = traits.position_alias; alias && od->contains(alias->index, alias->sub(1)))
    (void)od->set_hooks(alias->index, hooks);
}

void SimDevice::Impl::load_parameters(const EntrySelect& select, const NvImage* image) {
  for (const device::ObjectDesc& e : desc.entries) {
    if (is_string_type(e.data_type)) continue;
    const bool param = is_writable(*od, e.index, e.sub);
    if (!param && !e.default_value.plus_node_id) continue;
    if (!select(e)) continue;
    std::uint64_t v = factory_value(e, active_node);
    if (image != nullptr && param)
      if (const auto stored = image->get(e.index, e.sub)) v = *stored;
    (void)set_raw(*od, e.index, e.sub, v);
  }
  family_after_load();
}

}  // namespace cobridge::sim
