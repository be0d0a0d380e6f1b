// The node-ID decisions of one discovery session: the pure assignment
// (node_assignment.hpp) applied to what the identity probe knows now, with
// its effects recorded (promises, swaps, probes a decision waits for).
//
// Thread: the bus's control thread.
#pragma once

#include "config/config.hpp"
#include "bus/discovery.hpp"
#include "bus/discovery/identity_probe.hpp"
#include "bus/discovery/node_assignment.hpp"
#include "bus/state_store.hpp"

#include <cstdint>
#include <optional>
#include <vector>

namespace cobridge::bus::discovery {

// The bus's settings, as of the last (re)load.
struct BusSettings {
  DiscoveryOptions opt;
  config::Bus bus;
  std::vector<config::Device> devices;  // of this bus
  std::vector<Assignment> previous;     // the remembered table of this bus
  // serial -> VendorNumber of the device's EDS file, for devices described by
  // `eds` whose configuration names no vendor (Fastscan confirms it whole).
  std::vector<std::pair<std::uint32_t, std::uint32_t>> eds_vendors;
  canopen::Duration sdo_timeout{};
  canopen::Duration lss_timeout{};
};

class Decisions {
 public:
  Decisions(const BusSettings& settings, IdentityProbe& probe) : s_(settings), probe_(probe) {}

  Decision decide(const LssAddress& a);
  Placement place(const LssAddress& a, std::uint8_t back_to, bool unknown_policy);

  [[nodiscard]] bool node_free_for(std::uint8_t node, const LssAddress& a) const {
    return discovery::node_free_for(node, a, probe_.picture(), session_);
  }
  [[nodiscard]] std::optional<std::uint8_t> assigned_to(const LssAddress& a) const {
    return discovery::assigned_to(a, session_);
  }
  [[nodiscard]] const config::Device* configured_by_serial(std::uint32_t serial) const {
    return discovery::configured_by_serial(serial, s_.devices);
  }
  // Promise node-ID `node` to device `a`.
  void remember(const LssAddress& a, std::uint8_t node);
  [[nodiscard]] const Session& session() const noexcept { return session_; }

  // Every node had its chance to answer since start() (the start-up probe is over).
  bool initial_probe_done = false;
  // The presence picture changed: the unknown devices are decided again.
  bool presence_changed = false;

 private:
  [[nodiscard]] AssignmentInput input() const;
  void apply(const Effects& e);

  const BusSettings& s_;
  IdentityProbe& probe_;
  Session session_;
};

}  // namespace cobridge::bus::discovery
