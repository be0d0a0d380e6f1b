// The model table behind `--device MODEL`: the device families' models
// (daemon/families: product codes, factory node-IDs and bit rates,
// EDS files) as the simulator names them. A model with a product code from
// before a firmware change (multiturn before E§13 V03) is offered a second
// time under its legacy name ("MC1-2800-V02") reporting that code; ifm
// reports the product code as the EDS reads F§7.3's "0x43 0x41".
#include "device/sim_device.hpp"

#include <cctype>
#include <vector>

#include "families/family.hpp"

namespace cobridge::sim {

namespace {

namespace fam = cobridge::families;

ModelInfo model_info(const fam::Family& f, const fam::Model& m, std::string_view name, std::uint32_t product) {
  return ModelInfo{name, f.id, f.vendor, product, f.factory_node_id, m.legacy_rsx_rfx, m.eds_stem,
                   f.factory_bitrate_kbit};
}

// Per family: its models, then their legacy-product twins.
std::vector<ModelInfo> build_table() {
  std::vector<ModelInfo> out;
  for (const fam::Family* f : fam::all()) {
    std::vector<ModelInfo> legacy;
    for (const fam::Model& m : f->models) {
      if (!m.simulated) continue;
      out.push_back(model_info(*f, m, m.name, m.products.empty() ? f->simulated_product : m.products[0]));
      if (!m.legacy_product_name.empty() && m.products.size() > 1)
        legacy.push_back(model_info(*f, m, m.legacy_product_name, m.products[1]));
    }
    out.insert(out.end(), legacy.begin(), legacy.end());
  }
  return out;
}

const std::vector<ModelInfo>& table() noexcept {
  static const std::vector<ModelInfo> models = build_table();
  return models;
}

bool equal_ignore_case(std::string_view a, std::string_view b) noexcept {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto ca = static_cast<unsigned char>(a[i]);
    const auto cb = static_cast<unsigned char>(b[i]);
    if (std::tolower(ca) != std::tolower(cb)) return false;
  }
  return true;
}

}  // namespace

const ModelInfo* find_model(std::string_view name) noexcept {
  for (const ModelInfo& m : table())
    if (equal_ignore_case(m.name, name)) return &m;
  return nullptr;
}

std::span<const ModelInfo> all_models() noexcept { return table(); }

const fam::Family& family_facts(FamilyId f) noexcept { return fam::family(f); }

std::string_view family_name(FamilyId f) noexcept { return family_facts(f).name; }

}  // namespace cobridge::sim
