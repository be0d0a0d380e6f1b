#include "app/validation.hpp"

#include "app/exposure.hpp"
#include "base/number_text.hpp"

#include "config/known_models.hpp"
#include "config/load.hpp"
#include "device/eds.hpp"
#include "device/family_profile.hpp"

#include <algorithm>
#include <cstdio>
#include <string_view>
#include <system_error>

namespace cobridge::app {
namespace {

Error at(const config::SourceLocation& where, std::string message) {
  return config::to_error(config::Diagnostic{where.file, where.line, where.column, std::move(message)});
}

bool same_file(const std::filesystem::path& a, const std::filesystem::path& b) {
  std::error_code ec;
  return std::filesystem::equivalent(a, b, ec);
}

// A device with its own EDS file: the file must parse, match the identity
// the configuration gives, name a known family, and join the catalog.
void check_eds_device(const config::Device& d, device::DeviceCatalog& catalog, std::vector<Error>& errors) {
  const std::string who = "device \"" + d.name + "\": ";
  device::EdsResult r = device::load_eds_file(d.eds);
  if (!r.ok()) {
    errors.push_back(at(d.where, who + "eds file " + d.eds.string() + " is not a valid EDS (" +
                                     std::to_string(r.errors.size()) + " problem" +
                                     (r.errors.size() == 1 ? "" : "s") + ", listed below)"));
    std::stable_sort(r.errors.begin(), r.errors.end(),
                     [](const device::EdsError& a, const device::EdsError& b) { return a.line < b.line; });
    for (const auto& e : r.errors) errors.push_back(device::to_error(e));
    return;
  }
  const auto& info = r.description->device_info;
  if (d.vendor && *d.vendor != info.vendor_number)
    errors.push_back(at(d.where, who + "vendor " + hex(*d.vendor) + " differs from the eds file's VendorNumber " +
                                     hex(info.vendor_number)));
  if (d.product && *d.product != info.product_number &&
      std::find(r.description->selection.additional_products.begin(),
                r.description->selection.additional_products.end(),
                *d.product) == r.description->selection.additional_products.end())
    errors.push_back(at(d.where, who + "product " + hex(*d.product) + " differs from the eds file's ProductNumber " +
                                     hex(info.product_number)));
  if (!device::family_profile_for(*r.description))
    errors.push_back(at(d.where, who + "eds file " + d.eds.string() + " names no device family cobridge knows "
                                     "([Cobridge] Family, see docs/devices.md)"));
  const auto all = catalog.all();
  const bool loaded = std::any_of(all.begin(), all.end(), [&](const device::DeviceDescription* x) {
    return same_file(x->source, d.eds);
  });
  // The same device may already be described by a directory's file; the
  // bus manager then selects by identity, which names the same device.
  if (!loaded) (void)catalog.load_file(d.eds);
}

// A device named by model: some description in the catalog must be of that
// vendor, family, product and channel variant.
void check_model_device(const config::Config& cfg, const config::Device& d, const device::DeviceCatalog& catalog,
                        std::vector<Error>& errors) {
  const config::KnownModel* km = config::find_model(d.model);
  if (km == nullptr) return;  // the config loader has reported it
  const std::string_view family = families::family(km->family).name;  // EDS [Cobridge] Family
  const std::string variant = d.channels ? std::to_string(*d.channels) + "ch" : "";
  bool found = false;
  for (const auto* x : catalog.all()) {
    if (x->device_info.vendor_number != km->vendor || x->selection.family != family) continue;
    if (!km->products.empty()) {
      const auto& extra = x->selection.additional_products;
      const bool product_ok =
          std::any_of(km->products.begin(), km->products.end(), [&](std::uint32_t p) {
            return p == x->device_info.product_number || std::find(extra.begin(), extra.end(), p) != extra.end();
          });
      if (!product_ok) continue;
    }
    if (!variant.empty() && !x->selection.variant.empty() && x->selection.variant != variant) continue;
    found = true;
    break;
  }
  if (!found) {
    std::string dirs;
    for (const auto& dir : cfg.gateway.device_dirs) dirs += (dirs.empty() ? "" : ", ") + dir.string();
    errors.push_back(at(d.where, "device \"" + d.name + "\": model " + d.model +
                                     " has no device description (an EDS with VendorNumber " + hex(km->vendor) +
                                     " and [Cobridge] Family=" + std::string(family) +
                                     (variant.empty() ? "" : ", Variant=" + variant) + ") in " +
                                     (dirs.empty() ? "no device directory" : dirs)));
  }
}

// Loads the device descriptions the configuration asks for and checks that
// every device's model or EDS resolves to one: the part of validation the
// config layer cannot do (it links no device layer). Problems with files of a
// device directory that no device needs are warnings; the daemon skips them.
void load_catalog(const config::Config& cfg, device::DeviceCatalog& catalog, std::vector<Error>& errors,
                  std::vector<std::string>& warnings) {
  for (const auto& dir : cfg.gateway.device_dirs) {
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec)) {
      warnings.push_back("device directory " + dir.string() + " does not exist");
      continue;
    }
    for (const auto& e : catalog.load_directory(dir)) warnings.push_back(e.to_string() + " (file skipped)");
  }
  for (const auto& d : cfg.devices) {
    if (!d.eds.empty()) check_eds_device(d, catalog, errors);
  }
  for (const auto& d : cfg.devices) {
    if (!d.model.empty()) check_model_device(cfg, d, catalog, errors);
  }
}

}  // namespace

Validated validate(const std::filesystem::path& file) {
  Validated v;
  config::LoadResult r = config::load(file);
  if (!r) {
    for (const auto& d : r.diagnostics()) v.errors.push_back(config::to_error(d));
    return v;
  }
  v.catalog = std::make_unique<device::DeviceCatalog>();
  load_catalog(r.config(), *v.catalog, v.errors, v.warnings);
  for (auto& w : exposure_warnings(r.config())) v.warnings.push_back(std::move(w));
  if (v.errors.empty()) v.config = std::move(r).config();
  return v;
}

void print(const Validated& v, std::FILE* to) {
  for (const auto& w : v.warnings) std::fprintf(to, "warning: %s\n", w.c_str());
  for (const auto& e : v.errors) std::fprintf(to, "%s\n", e.to_string().c_str());
}

}  // namespace cobridge::app
