// What the encoder families can do over LSS, and how to set the node-ID by
// SDO where they cannot (J§1.3.3, E§4.3, F§7.4): the discovery's view of the family
// facts in families (which family is pre-Fastscan, which object holds
// the node-ID, which 0x1010 sub-index stores it).
//
// Thread: any; constants only.
#pragma once

#include "canopen/lss.hpp"
#include "families/family.hpp"
#include "families/ifm_rm.hpp"
#include "families/novotechnik.hpp"

#include <cstdint>
#include <optional>
#include <span>

namespace cobridge::bus::discovery {

inline constexpr std::uint32_t kVendorNovotechnik = families::kNovotechnikVendor;
inline constexpr std::uint32_t kVendorIfm = families::kIfmVendor;

// A device of a family whose LSS is older than Fastscan (the rotary series
// claims DSP-305 V1.1.2, J§1 intro): such devices are separated by Slowscan.
[[nodiscard]] bool is_pre_fastscan(std::uint32_t vendor, std::uint32_t product) noexcept;
// The product codes of the pre-Fastscan families, in registry order, as a
// range (for (std::uint32_t p : kPreFastscanProducts)).
[[nodiscard]] std::span<const std::uint32_t> pre_fastscan_products() noexcept;
struct PreFastscanProducts {
  [[nodiscard]] auto begin() const noexcept { return pre_fastscan_products().begin(); }
  [[nodiscard]] auto end() const noexcept { return pre_fastscan_products().end(); }
};
inline constexpr PreFastscanProducts kPreFastscanProducts{};

// The node-ID object of a family without (documented) LSS answers, and the
// 0x1010 sub-index whose 'save' covers it.
struct SdoNodeIdObject {
  std::uint16_t index = 0;
  std::uint8_t minus = 0;     // value written = node-ID - minus (ifm: F§7.4 "always add 1")
  std::uint8_t save_sub = 0;  // 0x1010 sub-index that covers the node-ID
};
[[nodiscard]] std::optional<SdoNodeIdObject> sdo_node_id_object(const canopen::LssAddress& a) noexcept;

inline constexpr std::uint16_t kStoreObject = families::kStoreObject;
inline constexpr std::uint32_t kSaveSignature = families::kSaveSignature;

}  // namespace cobridge::bus::discovery
