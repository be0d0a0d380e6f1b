#include "device/device_catalog.hpp"

#include "base/number_text.hpp"
#include "device/eds_check.hpp"

#include <algorithm>
#include <iterator>
#include <map>
#include <string>
#include <system_error>

namespace cobridge::device {

namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return out;
}

bool has_product(const DeviceDescription& d, std::uint32_t product) {
  if (d.device_info.product_number == product) return true;
  const auto& extra = d.selection.additional_products;
  return std::find(extra.begin(), extra.end(), product) != extra.end();
}

bool products_overlap(const DeviceDescription& a, const DeviceDescription& b) {
  if (a.selection.match_any_product && b.selection.match_any_product) return true;
  if (has_product(b, a.device_info.product_number)) return true;
  for (const std::uint32_t p : a.selection.additional_products) {
    if (has_product(b, p)) return true;
  }
  return false;
}

}  // namespace

std::vector<EdsError> DeviceCatalog::load_directory(const std::filesystem::path& dir) noexcept {
  std::vector<EdsError> out;
  try {
    std::error_code ec;
    std::vector<std::filesystem::path> files;
    for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
      const auto& p = it->path();
      std::error_code fec;
      if (lower(p.extension().string()) == ".eds" && it->is_regular_file(fec)) files.push_back(p);
    }
    if (ec) {
      out.push_back({dir.string(), 0, 0, EdsErrc::kIo, "cannot read the device directory: " + ec.message()});
      errors_.insert(errors_.end(), out.begin(), out.end());
      return out;
    }
    std::sort(files.begin(), files.end());  // deterministic order of errors
    for (const auto& f : files) {
      auto errs = load_file(f);
      out.insert(out.end(), errs.begin(), errs.end());
    }
  } catch (...) {
    out.push_back({"<device directory>", 0, 0, EdsErrc::kIo, "out of memory while loading the device directory"});
  }
  return out;
}

std::vector<EdsError> DeviceCatalog::load_file(const std::filesystem::path& path) noexcept {
  EdsResult r = load_eds_file(path);
  if (!r.ok()) {
    try {
      errors_.insert(errors_.end(), r.errors.begin(), r.errors.end());
    } catch (...) {
    }
    return std::move(r.errors);
  }
  return add(std::move(*r.description));
}

std::vector<EdsError> DeviceCatalog::add(DeviceDescription description) noexcept {
  try {
    auto errs = add_checked(std::move(description));
    errors_.insert(errors_.end(), errs.begin(), errs.end());
    return errs;
  } catch (...) {
    return {};
  }
}

std::vector<EdsError> DeviceCatalog::add_checked(DeviceDescription d) {
  const auto& id = d.device_info;
  for (const auto& other : descriptions_) {
    const auto& oid = other->device_info;
    if (oid.vendor_number == id.vendor_number && oid.revision_number == id.revision_number &&
        lower(other->selection.variant) == lower(d.selection.variant) && products_overlap(*other, d)) {
      std::string msg = "duplicate identity: vendor " + hex(id.vendor_number, 8) + " product " +
                        hex(id.product_number, 8) + " revision " + hex(id.revision_number, 8);
      if (!d.selection.variant.empty()) msg += " variant '" + d.selection.variant + "'";
      msg += " is also described by " + other->source + "; " + d.source + " is not loaded";
      return {EdsError{d.source, 0, 0, EdsErrc::kDuplicateIdentity, std::move(msg)}};
    }
  }
  descriptions_.push_back(std::make_unique<const DeviceDescription>(std::move(d)));
  return {};
}

std::vector<const DeviceDescription*> DeviceCatalog::matching(std::uint32_t vendor, std::uint32_t product,
                                                               std::optional<std::uint32_t> revision,
                                                               std::optional<std::string_view> variant) const {
  std::vector<const DeviceDescription*> found;
  for (const auto& d : descriptions_) {
    if (d->device_info.vendor_number == vendor && has_product(*d, product)) found.push_back(d.get());
  }
  if (found.empty()) {
    for (const auto& d : descriptions_) {
      if (d->device_info.vendor_number == vendor && d->selection.match_any_product) found.push_back(d.get());
    }
  }
  if (variant) {
    const std::string v = lower(*variant);
    std::erase_if(found, [&](const DeviceDescription* d) { return lower(d->selection.variant) != v; });
  }
  // Per variant, the newest description not newer than the device.
  std::map<std::string, const DeviceDescription*> best;
  for (const DeviceDescription* d : found) {
    const std::uint32_t rev = d->device_info.revision_number;
    if (revision && rev > *revision) continue;
    auto& slot = best[lower(d->selection.variant)];
    if (slot == nullptr || rev > slot->device_info.revision_number) slot = d;
  }
  std::vector<const DeviceDescription*> out;
  for (const auto& [name, d] : best) out.push_back(d);
  return out;
}

const DeviceDescription* DeviceCatalog::select(std::uint32_t vendor, std::uint32_t product,
                                               std::optional<std::uint32_t> revision,
                                               std::string_view variant) const noexcept {
  try {
    const auto found = matching(vendor, product, revision,
                                variant.empty() ? std::nullopt : std::optional<std::string_view>{variant});
    return found.size() == 1 ? found.front() : nullptr;
  } catch (...) {
    return nullptr;
  }
}

std::vector<const DeviceDescription*> DeviceCatalog::candidates(std::uint32_t vendor, std::uint32_t product,
                                                                std::optional<std::uint32_t> revision) const {
  return matching(vendor, product, revision, std::nullopt);
}

std::vector<Error> DeviceCatalog::check() const {
  std::vector<Error> out;
  for (const auto& d : descriptions_) {
    auto findings = check_eds(*d);
    out.insert(out.end(), std::make_move_iterator(findings.begin()), std::make_move_iterator(findings.end()));
  }
  return out;
}

std::vector<const DeviceDescription*> DeviceCatalog::all() const {
  std::vector<const DeviceDescription*> out;
  out.reserve(descriptions_.size());
  for (const auto& d : descriptions_) out.push_back(d.get());
  return out;
}

}  // namespace cobridge::device
