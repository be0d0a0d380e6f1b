// The known models are the device families' models (families), seen
// with the configuration's Family enum.
#include "config/known_models.hpp"

#include <algorithm>
#include <array>
#include <utility>
#include <vector>

#include "families/family.hpp"
#include "families/ifm_rm.hpp"
#include "families/novotechnik_multiturn.hpp"
#include "families/novotechnik_rotary.hpp"

namespace cobridge::config {
namespace {

namespace fam = device::families;

// The configuration's name for each family module.
const std::array<std::pair<const fam::Family*, Family>, 3> kFamilyEnum{{
    {&fam::kNovotechnikRotary, Family::novotechnik_rotary},
    {&fam::kNovotechnikMultiturn, Family::novotechnik_multiturn},
    {&fam::kIfmRm, Family::ifm_rm},
}};

Family family_enum(const fam::Family& f) noexcept {
  const auto* it = std::find_if(kFamilyEnum.begin(), kFamilyEnum.end(), [&f](const auto& p) { return p.first == &f; });
  return it != kFamilyEnum.end() ? it->second : Family::ifm_rm;
}

std::vector<KnownModel> build_table() {
  std::vector<KnownModel> out;
  for (const fam::Family* f : fam::all()) {
    for (const fam::Model& m : f->models) {
      out.push_back(KnownModel{m.name, family_enum(*f), f->vendor, m.products, m.max_channels, m.cams_per_channel,
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
