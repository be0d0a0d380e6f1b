#include "dds/device_slots.hpp"

#include <cstddef>
#include <cstring>

namespace cobridge::dds {

template <std::size_t N>
void FixedString<N>::assign(const char* s) noexcept {
  std::size_t n = s != nullptr ? std::strlen(s) : 0;
  if (n > N - 1) {
    n = N - 1;
    // Do not cut a multi-byte UTF-8 character: back off continuation bytes
    // (10xxxxxx) and the lead byte they belong to.
    while (n > 0 && (static_cast<unsigned char>(s[n]) & 0xC0U) == 0x80U) --n;
  }
  if (n > 0) std::memcpy(text.data(), s, n);
  text[n] = '\0';
}

template struct FixedString<16>;
template struct FixedString<32>;
template struct FixedString<48>;
template struct FixedString<64>;

DeviceSlots::DeviceSlots(std::size_t capacity) : slots_(capacity) {}

DeviceSlot* DeviceSlots::find(std::uint16_t device_index) noexcept {
  return device_index < slots_.size() ? &slots_[device_index] : nullptr;
}

const DeviceSlot* DeviceSlots::find(std::uint16_t device_index) const noexcept {
  return device_index < slots_.size() ? &slots_[device_index] : nullptr;
}

DeviceSlot* DeviceSlots::apply(const cobridge_device_info& info) noexcept {
  DeviceSlot* slot = find(info.device_index);
  if (slot == nullptr) return nullptr;
  if (info.change == COBRIDGE_DEVICE_REMOVED) {
    *slot = DeviceSlot{};
    return slot;
  }
  slot->in_use = true;
  slot->announced = true;
  slot->bus_index = info.bus_index;
  slot->node_id = info.node_id;
  slot->vendor_id = info.vendor_id;
  slot->product_code = info.product_code;
  slot->revision = info.revision;
  slot->serial = info.serial;
  slot->name.assign(info.name);
  slot->bus_name.assign(info.bus_name);
  slot->model.assign(info.model);
  slot->family.assign(info.family);
  slot->position_unit.assign(info.position_unit);
  // A host older than ABI 6 says nothing of it: as configured.
  const bool has_config_state = info.struct_size >= offsetof(cobridge_device_info, config_state) + 1;
  slot->config_state = has_config_state ? info.config_state : std::uint8_t{COBRIDGE_CONFIG_AS_CONFIGURED};
  return slot;
}

bool is_status_kind(const cobridge_sample& s) noexcept {
  return s.kind == COBRIDGE_SAMPLE_HEARTBEAT || s.kind == COBRIDGE_SAMPLE_NMT_STATE ||
         s.kind == COBRIDGE_SAMPLE_STATUS;
}

StatusChange DeviceSlots::apply(const cobridge_sample& s) noexcept {
  DeviceSlot* slot = find(s.device_index);
  if (slot == nullptr) return StatusChange::kNone;
  bool older = false;
  if (slot->ahead) {
    // Wrap-safe: the sequence counts every sample of the device.
    const auto d = static_cast<std::int32_t>(s.sequence - slot->ahead_sequence);
    if (d > 0) {
      slot->ahead = false;  // the queue has passed what the lane applied
    } else {
      if (is_status_kind(s)) return StatusChange::kNone;  // applied ahead, or older than the state shown
      older = true;
    }
  }
  return update(*slot, s, older);
}

StatusChange DeviceSlots::apply_ahead(const cobridge_sample& s) noexcept {
  DeviceSlot* slot = find(s.device_index);
  if (slot == nullptr || !is_status_kind(s)) return StatusChange::kNone;
  slot->ahead = true;
  slot->ahead_sequence = s.sequence;
  return update(*slot, s, false);
}

StatusChange DeviceSlots::update(DeviceSlot& slot, const cobridge_sample& s, bool older_than_shown) noexcept {
  if (!slot.in_use) {
    // A device the host has not announced (yet): keyed by what the sample says.
    slot.in_use = true;
    slot.bus_index = s.bus_index;
    slot.node_id = s.node_id;
  }
  const DeviceState before = slot.state;
  DeviceState& st = slot.state;
  const unsigned valid = s.valid;
  switch (s.kind) {
    case COBRIDGE_SAMPLE_TPDO:
      slot.last_tpdo = s;
      slot.has_last_tpdo = true;
      // A fresh TPDO is current by definition (the decoder clears its stale
      // flag the same way), so a stale status ends here; unless a status
      // newer than this TPDO was applied ahead of the queue.
      if (!older_than_shown) st.stale = false;
      break;
    case COBRIDGE_SAMPLE_EMCY:
      if ((valid & COBRIDGE_VALID_EMCY) != 0) {
        st.last_emcy_code = s.emcy_code;
        st.last_emcy_register = s.emcy_register;
        st.last_emcy_ns = s.rx_timestamp_ns;
      }
      break;
    case COBRIDGE_SAMPLE_HEARTBEAT:
      // CiA 301 §7.2.8.3.2: a heartbeat proves the node alive and carries its state.
      st.online = true;
      if ((valid & COBRIDGE_VALID_NMT_STATE) != 0) st.nmt_state = s.nmt_state;
      break;
    case COBRIDGE_SAMPLE_NMT_STATE:
      if ((valid & COBRIDGE_VALID_NMT_STATE) != 0) st.nmt_state = s.nmt_state;
      break;
    case COBRIDGE_SAMPLE_STATUS:
      if ((valid & COBRIDGE_VALID_STATUS) != 0) {
        st.online = s.online != 0;
        st.stale = s.stale != 0;
      }
      if ((valid & COBRIDGE_VALID_NMT_STATE) != 0) st.nmt_state = s.nmt_state;
      break;
    default:
      break;
  }
  if (st.same_as(before)) return StatusChange::kNone;
  st.updated_ns = s.rx_timestamp_ns;
  return (st.stale && !before.stale) ? StatusChange::kBecameStale : StatusChange::kChanged;
}

}  // namespace cobridge::dds
