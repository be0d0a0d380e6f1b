// What the three encoder families can do over LSS, and how to set the
// node-ID by SDO where they cannot (digest G.6). To be replaced by
// device::FamilyProfile (daemon/device/family_profile.hpp) once it exists.
//
// Thread: any; constants only.
#pragma once

#include "canopen/lss.hpp"

#include <array>
#include <cstdint>
#include <optional>

namespace cobridge::gateway::discovery {

inline constexpr std::uint32_t kVendorNovotechnik = 0x00000182;  // J§1.2.1, E§4.1
inline constexpr std::uint32_t kVendorIfm = 0x0069666D;          // F§7.3

// The rotary series claims DSP-305 V1.1.2, older than Fastscan (digest Y.2):
// these devices are separated by Slowscan. Product codes from J§1.2.1.
inline constexpr std::array<std::uint32_t, 5> kPreFastscanProducts{0x0BE0, 0x0BF3, 0x0BBD, 0x0BCD, 0x0BE1};
[[nodiscard]] bool is_pre_fastscan(std::uint32_t vendor, std::uint32_t product) noexcept;

// The node-ID object of a family without (documented) LSS answers, and the
// 0x1010 sub-index whose 'save' covers it.
struct SdoNodeIdObject {
  std::uint16_t index = 0;
  std::uint8_t minus = 0;     // value written = node-ID - minus (ifm: F§7.4 "always add 1")
  std::uint8_t save_sub = 0;  // 0x1010 sub-index that covers the node-ID
};
[[nodiscard]] std::optional<SdoNodeIdObject> sdo_node_id_object(const canopen::LssAddress& a) noexcept;

inline constexpr std::uint16_t kStoreObject = 0x1010;        // CiA 301 store parameters
inline constexpr std::uint32_t kSaveSignature = 0x65766173;  // "save" (J§1.6.1, E§11, F§6.3.3)

}  // namespace cobridge::gateway::discovery
