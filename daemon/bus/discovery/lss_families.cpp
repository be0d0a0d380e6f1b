// LSS abilities of the families: see lss_families.hpp.
#include "bus/discovery/lss_families.hpp"

#include <vector>

#include "families/novotechnik_rotary.hpp"

namespace cobridge::bus::discovery {

namespace fam = cobridge::families;

namespace {
std::vector<std::uint32_t> collect_pre_fastscan_products() {
  std::vector<std::uint32_t> out;
  for (const fam::Family* f : fam::all()) {
    if (f->lss_fastscan) continue;
    for (const fam::Model& m : f->models) out.insert(out.end(), m.products.begin(), m.products.end());
  }
  return out;
}
}  // namespace

std::span<const std::uint32_t> pre_fastscan_products() noexcept {
  static const std::vector<std::uint32_t> products = collect_pre_fastscan_products();
  return products;
}

bool is_pre_fastscan(std::uint32_t vendor, std::uint32_t product) noexcept {
  const fam::Family* f = fam::family_of(vendor, product);
  return f != nullptr && !f->lss_fastscan;
}

std::optional<SdoNodeIdObject> sdo_node_id_object(const canopen::LssAddress& a) noexcept {
  const fam::Family* f = fam::family_of(a.vendor, a.product);
  if (f == nullptr) return std::nullopt;
  const fam::Addressing& how = f->addressing;
  std::uint8_t save_sub = f->store.node_id;  // J§1.6.1, E§7.1 / E§11, F§6.3.3
  if (f == &fam::kNovotechnikRotary && fam::is_legacy_rsx_rfx(a.product)) save_sub = fam::kRotaryLegacyNodeIdStoreSub;
  return SdoNodeIdObject{how.node_id_index, how.node_id_offset, save_sub};
}

}  // namespace cobridge::bus::discovery
