// Fastscan search: see fastscan_search.hpp.
#include "bus/discovery/fastscan_search.hpp"

#include "canopen/cob_id.hpp"
#include "config/known_models.hpp"
#include "bus/discovery/lss_families.hpp"
#include "bus/fastscan_knowledge.hpp"

#include <algorithm>
#include <optional>

namespace cobridge::bus::discovery {

namespace {

bool is_present_serial(std::uint32_t serial, const BusPicture& picture) {
  for (std::uint8_t x = 1; x <= 127; ++x)
    for (const auto& id : picture[x].ids)
      if (id.serial == serial) return true;
  return false;
}

}  // namespace

std::vector<Task> FastscanSearch::searches(canopen::TimePoint now, const BusSettings& s,
                                           const BusPicture& picture) const {
  if (now >= general_not_before_) return {make(Op::fastscan_loop)};
  if (plan(false, s, picture, {}, {}).size() > 0) return {make(Op::fastscan_known)};
  return {};
}

canopen::FastscanPlan FastscanSearch::plan(bool general, const BusSettings& s, const BusPicture& picture,
                                           const std::vector<LssAddress>& known,
                                           const std::vector<LssAddress>& found) {
  FastscanKnowledge k;
  for (const auto& id : known)
    if (!is_pre_fastscan(id.vendor, id.product)) k.known.push_back(id);
  for (const auto& c : s.devices) {
    const config::KnownModel* m = c.model.empty() ? nullptr : config::find_model(c.model);
    if (m && !families::family(m->family).lss_fastscan) continue;  // no Fastscan (J§1 intro)
    const bool seen = std::any_of(found.begin(), found.end(), [&](const LssAddress& f) { return f.serial == c.serial; });
    if (c.serial != 0 && !seen && !is_present_serial(c.serial, picture)) k.absent.push_back(&c);
    if (general) k.models.push_back(&c);
  }
  k.remembered = s.previous;
  k.found = found;
  k.eds_vendors = s.eds_vendors;
  k.general = general;
  return make_fastscan_plan(k);
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

}  // namespace cobridge::bus::discovery
