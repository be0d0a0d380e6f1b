// DeviceRecord: a cobridge_device_info copied by value, strings into fixed
// arrays, so that on_device (the dispatcher thread) hands it to the
// publisher thread through an SpscRing without allocating. Longer strings
// are cut at the array's size (NUL-terminated), which only a device name
// of more than 63 bytes would notice.
//
// Thread contract: from_info() on the dispatcher thread (no allocation);
// the record is then read on the publisher thread.
#pragma once

#include <cobridge/plugin.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace cobridge::mqtt {

struct DeviceRecord {
  std::uint16_t device_index = 0;
  std::uint8_t bus_index = 0;
  std::uint8_t node_id = 0;
  std::uint8_t change = 0;  // enum cobridge_device_change
  std::uint32_t vendor_id = 0;
  std::uint32_t product_code = 0;
  std::uint32_t revision = 0;
  std::uint32_t serial = 0;
  char name[64] = {};
  char bus_name[32] = {};
  char model[64] = {};
  char family[32] = {};
  char position_unit[16] = {};
};
static_assert(std::is_trivially_copyable_v<DeviceRecord>, "copied through an SpscRing");

template <std::size_t N>
inline void copy_text(char (&dst)[N], const char* src) noexcept {
  std::size_t n = 0;
  if (src != nullptr) {
    while (n + 1 < N && src[n] != '\0') ++n;
    std::memcpy(dst, src, n);
  }
  dst[n] = '\0';
}

// The record of `info`; the strings past the struct_size the host gave stay "".
inline DeviceRecord from_info(const cobridge_device_info& info) noexcept {
  DeviceRecord r;
  r.device_index = info.device_index;
  r.bus_index = info.bus_index;
  r.node_id = info.node_id;
  r.change = info.change;
  r.vendor_id = info.vendor_id;
  r.product_code = info.product_code;
  r.revision = info.revision;
  r.serial = info.serial;
  if (info.struct_size >= offsetof(cobridge_device_info, position_unit) + sizeof(info.position_unit)) {
    copy_text(r.name, info.name);
    copy_text(r.bus_name, info.bus_name);
    copy_text(r.model, info.model);
    copy_text(r.family, info.family);
    copy_text(r.position_unit, info.position_unit);
  }
  return r;
}

}  // namespace cobridge::mqtt
