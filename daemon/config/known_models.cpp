// The known models are the device families' models (device/families), seen
// with the configuration's Family enum.
#include "config/known_models.hpp"

#include <vector>

#include "device/families/family.hpp"
#include "device/families/novotechnik_multiturn.hpp"
#include "device/families/novotechnik_rotary.hpp"

namespace cobridge::config {
namespace {

namespace fam = device::families;

Family family_enum(const fam::Family& f) noexcept {
  if (&f == &fam::kNovotechnikRotary) return Family::novotechnik_rotary;
  if (&f == &fam::kNovotechnikMultiturn) return Family::novotechnik_multiturn;
  return Family::ifm_rm;
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
