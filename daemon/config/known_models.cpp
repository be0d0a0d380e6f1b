// The known models are the device families' models (families).
#include "config/known_models.hpp"

#include <vector>

#include "families/family.hpp"

namespace cobridge::config {
namespace {

namespace fam = cobridge::families;

std::vector<KnownModel> build_table() {
  std::vector<KnownModel> out;
  for (const fam::Family* f : fam::all()) {
    for (const fam::Model& m : f->models) {
      out.push_back(KnownModel{m.name, f->id, f->vendor, m.products, m.max_channels, m.cams_per_channel,
                               m.position_filter, m.speed_filter});
    }
  }
  return out;
}

const std::vector<KnownModel>& table() noexcept {
  static const std::vector<KnownModel> models = build_table();
  return models;
}

}  // namespace

std::span<const KnownModel> known_models() noexcept { return table(); }

const KnownModel* find_model(std::string_view name) noexcept {
  for (const auto& m : table()) {
    if (m.name == name) return &m;
  }
  return nullptr;
}

}  // namespace cobridge::config
