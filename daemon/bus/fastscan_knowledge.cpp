#include "bus/fastscan_knowledge.hpp"

#include <optional>

#include "config/known_models.hpp"

namespace cobridge::bus {
namespace {

using canopen::FastscanPlan;
using canopen::FastscanTarget;
using U32 = std::optional<std::uint32_t>;

const Assignment* remembered_of(const config::Device& d, U32 vendor, std::span<const Assignment> remembered) {
  for (const auto& a : remembered)
    if (a.serial == d.serial && (!vendor || a.vendor == *vendor)) return &a;
  return nullptr;
}

// One target per product code the device may report (one with the product
// unknown when nothing names it).
U32 eds_vendor_of(const config::Device& d, std::span<const std::pair<std::uint32_t, std::uint32_t>> eds_vendors) {
  for (const auto& [serial, vendor] : eds_vendors)
    if (serial == d.serial) return vendor;
  return std::nullopt;
}

void add_device(FastscanPlan& plan, const config::Device& d, bool with_serial, const FastscanKnowledge& k) {
  const std::span<const Assignment> remembered = k.remembered;
  const config::KnownModel* m = d.model.empty() ? nullptr : config::find_model(d.model);
  const U32 vendor = d.vendor ? d.vendor : m ? U32(m->vendor) : eds_vendor_of(d, k.eds_vendors);
  const Assignment* seen = with_serial ? remembered_of(d, vendor, remembered) : nullptr;
  const U32 revision = seen && seen->revision != 0 ? U32(seen->revision) : std::nullopt;
  const U32 serial = with_serial ? U32(d.serial) : std::nullopt;
  std::vector<U32> products;
  if (d.product) products.emplace_back(*d.product);
  else if (seen && seen->product != 0) products.emplace_back(seen->product);
  else if (m) products.assign(m->products.begin(), m->products.end());
  if (products.empty()) products.emplace_back(std::nullopt);
  for (const U32& p : products) {
    // A device whose revision is not known most likely has the revision of
    // the devices of its model seen before: guessed first, searched when no
    // guess is answered (the target with the revision unknown stays).
    if (!revision) {
      for (const auto& a : remembered)
        if (a.revision != 0 && vendor == a.vendor && p == a.product)
          (void)plan.add(FastscanTarget::of(vendor, p, a.revision, serial));
      for (const auto& f : k.found)
        if (vendor == f.vendor && p == f.product)
          (void)plan.add(FastscanTarget::of(vendor, p, f.revision, serial));
    }
    (void)plan.add(FastscanTarget::of(vendor, p, revision, serial));
  }
}

}  // namespace

FastscanPlan make_fastscan_plan(const FastscanKnowledge& k) {
  FastscanPlan plan;
  for (const auto& a : k.known) (void)plan.add(FastscanTarget::of(a.vendor, a.product, a.revision, a.serial));
  for (const config::Device* d : k.absent) add_device(plan, *d, true, k);
  for (const config::Device* d : k.models) add_device(plan, *d, false, k);
  if (k.general) plan.search_unknown = true;
  return plan;
}

}  // namespace cobridge::bus
