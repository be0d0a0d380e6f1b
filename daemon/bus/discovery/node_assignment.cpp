// Node-ID assignment: see node_assignment.hpp. Decisions work on a copy of
// the session, so that a promise a swap gives up is already free for the
// target chosen next, exactly as when the caller records the effects.
#include "bus/discovery/node_assignment.hpp"

#include "canopen/cob_id.hpp"
#include "config/known_models.hpp"

#include <algorithm>

namespace cobridge::bus::discovery {

bool node_free_for(std::uint8_t node, const LssAddress& a, const BusPicture& picture, const Session& session) {
  if (!canopen::cob::valid_node_id(node)) return false;
  for (const auto& id : picture[node].ids)
    if (!same_device(id, a)) return false;
  if (picture[node].clash && picture[node].ids.empty()) return false;
  for (const auto& [id, n] : session.assigned)
    if (n == node && !same_device(id, a)) return false;
  return true;
}

std::optional<std::uint8_t> assigned_to(const LssAddress& a, const Session& session) {
  for (const auto& [id, n] : session.assigned)
    if (same_device(id, a)) return n;
  return std::nullopt;
}

const config::Device* configured_by_serial(std::uint32_t serial, const std::vector<config::Device>& devices) {
  for (const auto& d : devices)
    if (d.serial == serial) return &d;
  return nullptr;
}

bool model_matches(const config::Device& c, const LssAddress& a, bool need_info) {
  bool info = false;
  if (c.vendor) {
    info = true;
    if (*c.vendor != a.vendor) return false;
  }
  if (c.product) {
    info = true;
    if (*c.product != a.product) return false;
  }
  if (!c.model.empty()) {
    if (const auto* m = config::find_model(c.model)) {
      info = true;
      if (m->vendor != a.vendor) return false;
      if (!m->products.empty() && std::find(m->products.begin(), m->products.end(), a.product) == m->products.end())
        return false;
    }
  }
  return info || !need_info;
}

namespace {

enum class Presence : std::uint8_t { present, unsure, absent };

bool matches(const LssAddress& id, std::uint32_t serial, std::uint32_t vendor) noexcept {
  return id.serial == serial && (vendor == 0 || id.vendor == vendor);
}

class Decider {
 public:
  explicit Decider(const AssignmentInput& in) : in_(in), s_(in.session) {}

  Decision decide(const LssAddress& a) {
    Decision d;
    if (const config::Device* c = configured_by_serial(a.serial, in_.devices)) return decide_configured(*c, a);
    for (const auto& w : s_.swapped)
      if (same_device(w.by, a))
        for (const auto& c : in_.devices)
          if (c.name == w.name) {
            // A replacement decided before keeps the place it took.
            d.device = c.name;
            d.replaces = c.name;
            d.replaced = w.replaced;
            d.target = target_of(c, a, d.problem);
            return d;
          }
    if (in_.bus.swap_policy == config::SwapPolicy::same_model && decide_swap(a, d)) return d;
    d.problem = "unknown device " + describe(a) + ": not in the configuration, left alone";
    return d;
  }

  [[nodiscard]] bool free_for(std::uint8_t node, const LssAddress& a) const {
    return node_free_for(node, a, in_.picture, s_);
  }
  [[nodiscard]] std::optional<std::uint8_t> previous_node(std::uint32_t serial, std::optional<std::uint32_t> vendor,
                                                          std::optional<std::uint32_t> product) const {
    for (const auto& p : in_.previous)
      if (p.serial == serial && (!vendor || *vendor == p.vendor) && (!product || *product == p.product) &&
          canopen::cob::valid_node_id(p.node_id))
        return p.node_id;
    return std::nullopt;
  }
  [[nodiscard]] std::uint8_t pool_node(const LssAddress& a) const {
    for (std::uint8_t n : in_.bus.node_pool)
      if (!pool_node_taken(n, a)) return n;
    return 0;
  }

 private:
  Decision decide_configured(const config::Device& c, const LssAddress& a) {
    Decision d;
    d.device = c.name;
    if (!model_matches(c, a, false)) {
      d.problem = "device " + c.name + " (serial " + std::to_string(a.serial) + ") is of the wrong model: " +
                  describe(a) + (c.model.empty() ? "" : ", configured model " + c.model) + "; not configured";
      return d;
    }
    if (const Swap* w = swap_of(c.name); w != nullptr && !same_device(w->by, a)) {
      // The original is back after a replacement took its place.
      std::uint8_t probe = 0;
      switch (presence_of(w->by.serial, w->by.vendor, probe)) {
        case Presence::present:
          d.device.clear();
          d.problem = "device " + c.name + " (serial " + std::to_string(a.serial) + ") is back, but serial " +
                      std::to_string(w->by.serial) + " has taken its place (swap policy same-model); left alone";
          return d;
        case Presence::unsure:
          if (probe != 0) d.effects.probes.push_back(probe);
          d.device.clear();
          d.wait = true;
          return d;
        case Presence::absent: {
          // The replacement is gone too: the configured serial takes its place back.
          const LssAddress by = w->by;
          unswap(c.name, d.effects);
          forget(by, d.effects);
          d.replaces = c.name;
          d.replaced = by;
          break;
        }
      }
    }
    d.target = target_of(c, a, d.problem);
    return d;
  }

  // Swap policy same-model; false = no configured device's place for it.
  bool decide_swap(const LssAddress& a, Decision& d) {
    std::vector<const config::Device*> absent;
    bool wait = false;
    for (const auto& c : in_.devices) {
      if (!model_matches(c, a, true)) continue;
      std::uint8_t probe = 0;
      switch (holder_presence(c, probe)) {
        case Presence::present: break;
        case Presence::unsure:
          wait = true;
          if (probe != 0) d.effects.probes.push_back(probe);
          break;
        case Presence::absent: absent.push_back(&c); break;
      }
    }
    // Never a guess: a device whose loss is not yet confirmed keeps its
    // place, and a swap waits for the end of the probe round, whose later
    // nodes may show the missing device (booting at the same time).
    if (wait) {
      d.wait = true;
      return true;
    }
    if (!absent.empty() && in_.round_active) {
      d.wait = true;
      d.effects.recheck = true;
      return true;
    }
    if (absent.size() == 1) {
      const config::Device& c = *absent.front();
      const LssAddress old = holder_identity(c);
      forget(old, d.effects);
      unswap(c.name, d.effects);
      d.effects.swap = Swap{c.name, a, old};
      s_.swapped.push_back(*d.effects.swap);
      d.device = c.name;
      d.replaces = c.name;
      d.replaced = old;
      d.target = target_of(c, a, d.problem);
      return true;
    }
    if (absent.size() > 1) {
      std::string names;
      for (const auto* c : absent) names += (names.empty() ? "" : ", ") + c->name;
      d.problem = "unknown device " + describe(a) + " could replace any of the missing devices " + names +
                  " (swap policy same-model); left alone: give its serial in the configuration";
      return true;
    }
    return false;
  }

  std::uint8_t target_of(const config::Device& c, const LssAddress& a, std::string& why) const {
    if (c.node_id) return *c.node_id;
    if (auto p = previous_node(c.serial, c.vendor, c.product)) return *p;
    // A replacement after a restart: the state file has its own line since
    // the swap (the replaced device's line was erased then).
    if (a.serial != c.serial)
      if (auto p = previous_node(a.serial, a.vendor, a.product)) return *p;
    if (auto p = assigned_to(a, s_)) return *p;
    const std::uint8_t n = pool_node(a);
    if (n == 0) why = "node pool exhausted for " + c.name;
    return n;
  }

  [[nodiscard]] bool pool_node_taken(std::uint8_t n, const LssAddress& a) const {
    for (const auto& d : in_.devices)
      if (d.node_id && *d.node_id == n && d.serial != a.serial) return true;
    for (const auto& p : in_.previous)
      if (p.node_id == n && p.serial != a.serial) return true;
    return !free_for(n, a);
  }

  // Where device `serial` (of `vendor`, 0 = any) is, as far as the probes
  // and the bus manager's supervision tell. `probe` = a node whose probe
  // would settle an unsure answer.
  [[nodiscard]] Presence presence_of(std::uint32_t serial, std::uint32_t vendor, std::uint8_t& probe) const {
    bool unsure = false;
    const auto has = [&](const std::vector<LssAddress>& v) {
      return std::any_of(v.begin(), v.end(), [&](const LssAddress& id) { return matches(id, serial, vendor); });
    };
    for (std::uint8_t n = 1; n <= 127; ++n) {
      const NodePicture& node = in_.picture[n];
      // A clash whose identities the probe could not pair up still shows serials.
      const bool seen = has(node.ids) || (node.clash && node.seen[3].contains(serial) &&
                                          (vendor == 0 || node.seen[0].contains(vendor)));
      const bool was = has(node.last);
      if (node.supervised && (seen || was)) return Presence::present;
      if (node.unsure && (seen || was)) {
        unsure = true;
        probe = n;
        continue;
      }
      if (seen) return Presence::present;
    }
    if (unsure || !in_.initial_probe_done) return Presence::unsure;
    return Presence::absent;
  }
  [[nodiscard]] const Swap* swap_of(const std::string& name) const {
    for (const auto& w : s_.swapped)
      if (w.name == name) return &w;
    return nullptr;
  }
  // Who holds configured device c's place now: its replacement, else itself.
  [[nodiscard]] Presence holder_presence(const config::Device& c, std::uint8_t& probe) const {
    if (const Swap* w = swap_of(c.name)) return presence_of(w->by.serial, w->by.vendor, probe);
    return presence_of(c.serial, c.vendor.value_or(0), probe);
  }
  // The identity that held c's place, as well as it is known.
  [[nodiscard]] LssAddress holder_identity(const config::Device& c) const {
    if (const Swap* w = swap_of(c.name)) return w->by;
    for (const auto& p : in_.previous)
      if (p.serial == c.serial && (!c.vendor || *c.vendor == p.vendor) && (!c.product || *c.product == p.product))
        return LssAddress{p.vendor, p.product, p.revision, p.serial};
    for (const auto& [id, n] : s_.assigned)
      if (matches(id, c.serial, c.vendor.value_or(0))) return id;
    LssAddress a;
    a.serial = c.serial;
    a.vendor = c.vendor.value_or(0);
    a.product = c.product.value_or(0);
    return a;
  }
  void forget(const LssAddress& old, Effects& e) {
    e.forget = old;
    std::erase_if(s_.assigned, [&](const auto& p) { return matches(p.first, old.serial, old.vendor); });
  }
  void unswap(const std::string& name, Effects& e) {
    e.unswap = name;
    std::erase_if(s_.swapped, [&](const Swap& x) { return x.name == name; });
  }

  const AssignmentInput& in_;
  Session s_;
};

}  // namespace

Decision decide(const LssAddress& a, const AssignmentInput& in) { return Decider(in).decide(a); }

Placement place_non_configured(const LssAddress& a, std::uint8_t back_to, bool unknown_policy,
                               const AssignmentInput& in) {
  Decider decider(in);
  Placement p;
  p.decision = decider.decide(a);
  Decision& d = p.decision;
  if (d.target != 0 && decider.free_for(d.target, a)) {
    p.via = Placement::Via::decision;
    p.target = d.target;
  } else if (canopen::cob::valid_node_id(back_to) && decider.free_for(back_to, a)) {
    // (c) made it non-configured; it goes back where it was, unstored.
    p.via = Placement::Via::back;
    p.target = back_to;
  } else if (unknown_policy && d.device.empty() && in.bus.unknown_devices == config::UnknownDevices::assign) {
    // Policy assign: a node-ID from the pool (its earlier one when remembered), stored.
    p.target = decider.previous_node(a.serial, a.vendor, a.product).value_or(decider.pool_node(a));
    if (p.target == 0) {
      p.pool_exhausted = true;
    } else {
      p.via = Placement::Via::pool;
      d.problem.clear();
    }  // handled as configured: reported by the move, not as a problem
  }
  return p;
}

}  // namespace cobridge::bus::discovery
