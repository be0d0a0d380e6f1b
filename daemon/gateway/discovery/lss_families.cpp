// LSS abilities of the three families: see lss_families.hpp.
#include "gateway/discovery/lss_families.hpp"

#include <algorithm>

namespace cobridge::gateway::discovery {

bool is_pre_fastscan(std::uint32_t vendor, std::uint32_t product) noexcept {
  return vendor == kVendorNovotechnik &&
         std::find(kPreFastscanProducts.begin(), kPreFastscanProducts.end(), product) != kPreFastscanProducts.end();
}

namespace {
bool is_novotechnik_multiturn(std::uint32_t vendor, std::uint32_t product) noexcept {
  // E§4.1 and the pre-V03 codes of E§13.
  return vendor == kVendorNovotechnik &&
         (product == 0x0BB8 || product == 0x0BD5 || product == 0x0BB9 || product == 0x0BBC);
}
}  // namespace

std::optional<SdoNodeIdObject> sdo_node_id_object(const canopen::LssAddress& a) noexcept {
  if (a.vendor == kVendorIfm) return SdoNodeIdObject{0x3000, 1, 1};  // F§7.4, F§6.3.3 (0x1010/1 only)
  if (is_pre_fastscan(a.vendor, a.product)) {
    // J§1.6.1: 0x1010/4, except RSX-7900 / RFX-6900 which use 0x1010/1.
    const bool rsx_rfx = a.product == 0x0BCD || a.product == 0x0BE1;
    return SdoNodeIdObject{0x2000, 0, static_cast<std::uint8_t>(rsx_rfx ? 1 : 4)};
  }
  if (is_novotechnik_multiturn(a.vendor, a.product)) return SdoNodeIdObject{0x2000, 0, 4};  // E§7.1, E§11
  return std::nullopt;
}

}  // namespace cobridge::gateway::discovery
