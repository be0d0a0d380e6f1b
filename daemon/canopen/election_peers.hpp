// ElectionPeers: which node-IDs of a bus may be a gateway's, for the
// master election (canopen/master_election), and which of those are live.
//
// Any process may send any frame on a CAN bus, and a CAN frame does not say
// who sent it (docs/security.md "Raw CAN"). The election can only
// weigh what a frame names: a claim (0x71), an announcement (0x74) or a forced
// negotiation (0x76) counts when the node-ID and priority it names could be a
// gateway's (plausible: node-ID 1..127, not ours, priority 0..2 of CiA 302-2,
// never an excluded node-ID: a configured device's, a device known on the
// bus, the written node pool), and, where it matters, when that gateway is
// here now: it announced itself with that priority and its heartbeat was
// heard within the master timeout (live). A stranger must then forge a
// gateway's announcement and its heartbeat every period, not one frame.
//
// Thread: owned by MasterElection; one thread (the bus control thread) calls
// everything. No allocation, no locks.
#pragma once

#include <array>
#include <bitset>
#include <cstdint>

#include "canopen/clock.hpp"

namespace cobridge::canopen {

// Node-IDs (bit n = node-ID n) no gateway of the bus may have.
using NodeSet = std::bitset<128>;

class ElectionPeers {
 public:
  static constexpr uint8_t kLowestPriority = 2;  // CiA 302-2: priorities 0..2

  explicit ElectionPeers(uint8_t own_node) noexcept : own_(own_node) {}

  // May be called any time (a reload, a device given a node-ID).
  void set_excluded(const NodeSet& excluded) noexcept { excluded_ = excluded; }
  [[nodiscard]] const NodeSet& excluded() const noexcept { return excluded_; }

  // A claim or an announcement a gateway could have sent.
  [[nodiscard]] bool plausible(uint8_t priority, uint8_t node) const noexcept;
  // A plausible 0x74: `node` is a gateway with this priority from now on.
  // A gateway's priority is its configuration's: while its heartbeat is
  // heard (within `timeout`) an announcement with another priority is not
  // its own and is refused (false); after a silence (a restart) it counts.
  bool on_announce(uint8_t priority, uint8_t node, TimePoint now, Duration timeout) noexcept;
  [[nodiscard]] bool announced(uint8_t node) const noexcept { return node < 128 && announced_[node] && !excluded_[node]; }
  // A claim names its gateway's own priority (or a gateway not announced).
  [[nodiscard]] bool as_announced(uint8_t priority, uint8_t node) const noexcept {
    return !announced(node) || priority_[node] == priority;
  }
  // A heartbeat (any state) from a node the election owns.
  void heard(uint8_t node, TimePoint now) noexcept {
    if (node < 128) heard_at_[node] = now;
  }
  // Announced with `priority`, and its heartbeat heard within `timeout`.
  [[nodiscard]] bool live(uint8_t priority, uint8_t node, TimePoint now, Duration timeout) const noexcept;
  // Ours, announced, or `master` (the master followed), never excluded.
  [[nodiscard]] bool is_gateway(uint8_t node, uint8_t master) const noexcept;
  // The lowest announced node-ID not ours, else `master` unless ours; 0 = none.
  [[nodiscard]] uint8_t peer(uint8_t master) const noexcept;

 private:
  uint8_t own_;
  NodeSet excluded_;
  std::bitset<128> announced_;
  std::array<uint8_t, 128> priority_{};
  std::array<TimePoint, 128> heard_at_{};
};

}  // namespace cobridge::canopen
