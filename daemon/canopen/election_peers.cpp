#include "canopen/election_peers.hpp"

#include "canopen/cob_id.hpp"

namespace cobridge::canopen {

// One forged frame naming node 0, a device, or a priority CiA 302-2 does not
// have must not move the master role (docs/security.md "Raw CAN").
bool ElectionPeers::plausible(uint8_t priority, uint8_t node) const noexcept {
  return cob::valid_node_id(node) && node != own_ && priority <= kLowestPriority && !excluded_[node];
}

// Measured before this check: a forged 0x74 giving the live peer a better priority, then a
// claim with it, took the role from the master.
bool ElectionPeers::on_announce(uint8_t priority, uint8_t node, TimePoint now, Duration timeout) noexcept {
  if (!plausible(priority, node)) return false;
  const bool heard = heard_at_[node] != TimePoint{} && now - heard_at_[node] < timeout;
  if (announced_[node] && priority_[node] != priority && heard) return false;
  announced_.set(node);
  priority_[node] = priority;
  return true;
}

bool ElectionPeers::live(uint8_t priority, uint8_t node, TimePoint now, Duration timeout) const noexcept {
  if (!plausible(priority, node) || !announced(node) || priority_[node] != priority) return false;
  return heard_at_[node] != TimePoint{} && now - heard_at_[node] < timeout;
}

bool ElectionPeers::is_gateway(uint8_t node, uint8_t master) const noexcept {
  if (node == 0 || node >= 128 || excluded_[node]) return false;
  return node == own_ || announced_[node] || (node != 0 && node == master);
}

uint8_t ElectionPeers::peer(uint8_t master) const noexcept {
  for (uint8_t n = 1; n < 128; ++n) {
    if (announced(n) && n != own_) return n;
  }
  return master != own_ ? master : 0;
}

}  // namespace cobridge::canopen
