// Node-ID decisions of the session: see decisions.hpp.
#include "bus/discovery/decisions.hpp"

#include <algorithm>

namespace cobridge::bus::discovery {

AssignmentInput Decisions::input() const {
  return AssignmentInput{s_.bus, s_.devices, s_.previous, probe_.picture(), session_, initial_probe_done,
                         probe_.active()};
}

Decision Decisions::decide(const LssAddress& a) {
  Decision d = discovery::decide(a, input());
  apply(d.effects);
  return d;
}

Placement Decisions::place(const LssAddress& a, std::uint8_t back_to, bool unknown_policy) {
  Placement p = place_non_configured(a, back_to, unknown_policy, input());
  apply(p.decision.effects);
  return p;
}

void Decisions::remember(const LssAddress& a, std::uint8_t node) {
  for (auto& [id, n] : session_.assigned)
    if (same_device(id, a)) {
      n = node;
      return;
    }
  session_.assigned.emplace_back(a, node);
}

void Decisions::apply(const Effects& e) {
  if (e.forget) {
    // Its node-ID is no longer promised to it.
    const LssAddress& old = *e.forget;
    std::erase_if(session_.assigned, [&](const auto& p) {
      return p.first.serial == old.serial && (old.vendor == 0 || p.first.vendor == old.vendor);
    });
  }
  if (!e.unswap.empty()) std::erase_if(session_.swapped, [&](const Swap& x) { return x.name == e.unswap; });
  if (e.swap) session_.swapped.push_back(*e.swap);
  for (std::uint8_t n : e.probes) probe_.request(n);
  if (e.recheck) presence_changed = true;
}

}  // namespace cobridge::bus::discovery
