// Fastscan search: see fastscan_search.hpp.
#include "gateway/discovery/fastscan_search.hpp"

#include "canopen/cob_id.hpp"
#include "config/known_models.hpp"
#include "gateway/discovery/lss_families.hpp"

#include <algorithm>
#include <optional>

namespace cobridge::gateway::discovery {

namespace {

bool is_present_serial(std::uint32_t serial, const BusPicture& picture) {
  for (std::uint8_t x = 1; x <= 127; ++x)
    for (const auto& id : picture[x].ids)
      if (id.serial == serial) return true;
  return false;
}

// One Fastscan per configured device of this bus that is not present and
// whose serial and vendor are known (config, or its model), per product
// code its model may report.
void targeted(const std::vector<config::Device>& devices, const BusPicture& picture, std::vector<Task>& v) {
  for (const auto& c : devices) {
    if (c.serial == 0 || is_present_serial(c.serial, picture)) continue;
    const config::KnownModel* m = c.model.empty() ? nullptr : config::find_model(c.model);
    const std::optional<std::uint32_t> vendor = c.vendor ? c.vendor : m ? std::optional(m->vendor) : std::nullopt;
    if (!vendor) continue;
    std::vector<std::uint32_t> products;
    if (c.product) products.push_back(*c.product);
    else if (m) products.assign(m->products.begin(), m->products.end());
    if (products.empty()) products.push_back(0);  // unknown: searched
    for (const std::uint32_t product : products) {
      Ctx ctx;
      ctx.identity = LssAddress{*vendor, product, 0, c.serial};
      ctx.device = c.name;
      v.push_back(make(Op::fastscan_known, ctx));
    }
  }
}

}  // namespace

std::vector<Task> FastscanSearch::searches(canopen::TimePoint now, const std::vector<config::Device>& devices,
                                           const BusPicture& picture) const {
  std::vector<Task> v;
  targeted(devices, picture, v);
  if (now >= general_not_before_) {
    Task fs = make(Op::fastscan_loop);
    fs.node = 0;
    v.push_back(fs);
  }
  return v;
}

canopen::LssMaster::FastscanKnown FastscanSearch::known_fields(const LssAddress& a) {
  canopen::LssMaster::FastscanKnown k;
  k.vendor = a.vendor;
  if (a.product != 0) k.product = a.product;
  if (a.revision != 0) k.revision = a.revision;
  k.serial = a.serial;
  return k;
}

std::vector<Task> FastscanSearch::slowscan_all_pre_fastscan() {
  std::vector<Task> out;
  for (const std::uint32_t p : kPreFastscanProducts) {
    Task t = make(Op::slowscan_loop);
    t.node = 0;
    t.non_configured = true;
    t.range = canopen::LssRange{kVendorNovotechnik, p, 0, 0xFFFFFFFFu, 0, 0xFFFFFFFFu};
    out.push_back(t);
  }
  return out;
}

std::vector<Task> FastscanSearch::slowscan_of(const IdentityAnswers& v, std::uint8_t n, bool non_configured) {
  std::vector<Task> out;
  for (std::uint8_t iv = 0; iv < v[0].n; ++iv)
    for (std::uint8_t ip = 0; ip < v[1].n; ++ip) {
      if (!is_pre_fastscan(v[0].v[iv], v[1].v[ip])) continue;
      Task t = make(Op::slowscan_loop);
      t.node = n;
      t.non_configured = non_configured;
      t.range = canopen::LssRange{v[0].v[iv], v[1].v[ip], 0, 0xFFFFFFFFu, 0, 0xFFFFFFFFu};
      out.push_back(t);
    }
  return out;
}

bool FastscanSearch::is_stranger(const LssAddress& a) const {
  return std::any_of(strangers_.begin(), strangers_.end(), [&](const LssAddress& s) { return same_device(s, a); });
}

void FastscanSearch::note_stranger(const LssAddress& a, const std::string& why) {
  if (is_stranger(a)) return;
  strangers_.push_back(a);
  report_.problem("non-configured " + describe(a) + ": " + why, 0, a);
  DiscoveryEvent e;
  e.kind = DiscoveryEventKind::identified;
  e.node_id = canopen::cob::kNodeIdUnconfigured;
  e.identity = a;
  e.text = why;
  report_.event(std::move(e));
}

void FastscanSearch::back_off(canopen::TimePoint now, canopen::Duration discovery_period) {
  general_backoff_ = std::min(2 * general_backoff_ + discovery_period, canopen::Duration{std::chrono::minutes(10)});
  general_not_before_ = now + general_backoff_;
}

}  // namespace cobridge::gateway::discovery
