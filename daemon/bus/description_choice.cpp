#include "bus/description_choice.hpp"

#include <filesystem>
#include <optional>
#include <string>

#include "base/number_text.hpp"
#include "config/known_models.hpp"
#include "families/family.hpp"

namespace cobridge::bus {

namespace {

Result<DescriptionChoice> with_profile(const device::DeviceDescription& d) {
  auto profile = device::family_profile_for(d);
  if (!profile) return Error(Errc::kUnsupported, "description " + d.source + " names no known family");
  return DescriptionChoice{&d, *profile};
}

// The first loaded description of the model's vendor and family: for a
// model whose product code is not checkable (ifm, F§7.3).
const device::DeviceDescription* description_of_family(const device::DeviceCatalog& catalog,
                                                       const config::KnownModel& known) {
  for (const auto* d : catalog.all()) {
    if (d->device_info.vendor_number != known.vendor) continue;
    const auto profile = device::family_profile_for(*d);
    if (profile && profile->family == &families::family(known.family)) return d;
  }
  return nullptr;
}

const device::DeviceDescription* first_candidate(const device::DeviceCatalog& catalog, std::uint32_t vendor,
                                                 std::uint32_t product) {
  const auto candidates = catalog.candidates(vendor, product, std::nullopt);
  return candidates.empty() ? nullptr : candidates.front();
}

}  // namespace

Result<DescriptionChoice> choose_description(const device::DeviceCatalog& catalog, const config::Device& cfg,
                                             const canopen::LssAddress& id) {
  std::string variant;
  if (cfg.channels) variant = *cfg.channels == 2 ? "2ch" : "1ch";
  const device::DeviceDescription* d = nullptr;
  if (!cfg.eds.empty()) {
    for (const auto* c : catalog.all()) {
      if (std::filesystem::path(c->source) == cfg.eds) d = c;
    }
  }
  if (d == nullptr) d = catalog.select(id.vendor, id.product, id.revision, variant);
  if (d == nullptr && variant.empty()) {
    // Several variants: take the first candidate; its plan decides by what it finds.
    const auto c = catalog.candidates(id.vendor, id.product, id.revision);
    if (!c.empty()) d = c.front();
  }
  if (d == nullptr) {
    return Error(Errc::kNotFound, "no device description for vendor " + hex(id.vendor) + " product " +
                                      hex(id.product) + " revision " + hex(id.revision));
  }
  return with_profile(*d);
}

Result<DescriptionChoice> description_from_config(const device::DeviceCatalog& catalog, const config::Device& cfg,
                                                  const canopen::LssAddress& id) {
  const config::KnownModel* known = cfg.model.empty() ? nullptr : config::find_model(cfg.model);
  const device::DeviceDescription* d = nullptr;
  if (id.vendor != 0 && id.product != 0) {
    d = first_candidate(catalog, id.vendor, id.product);
  } else if (known != nullptr && !known->products.empty()) {
    d = first_candidate(catalog, known->vendor, known->products.front());
  }
  if (d == nullptr && known != nullptr) d = description_of_family(catalog, *known);
  if (d == nullptr) {
    return Error(Errc::kNotFound, "no device description for vendor " + hex(id.vendor) + " product " +
                                      hex(id.product) + (cfg.model.empty() ? "" : " nor model " + cfg.model));
  }
  return with_profile(*d);
}

}  // namespace cobridge::bus
