#include "dds/pair_role.hpp"

#include <algorithm>
#include <cstdint>

namespace cobridge::dds {
namespace {

const char* role_name(std::uint8_t role) noexcept {
  switch (role) {
    case COBRIDGE_ROLE_MASTER:
      return "master";
    case COBRIDGE_ROLE_STANDBY:
      return "standby";
    default:
      return "undecided";
  }
}

}  // namespace

bool PairRole::master_locked() const noexcept {
  for (const std::uint8_t r : roles_) {
    if (r == COBRIDGE_ROLE_MASTER) return true;
  }
  return false;
}

bool PairRole::update(const cobridge_role_info& info) {
  const std::lock_guard lock(mutex_);
  const bool before = master_locked();
  roles_[info.bus_index] = info.role;
  const bool after = master_locked();
  last_.node = node_;
  // Master of any bus reads "master": that is the gateway whose stream the
  // subscribers see.
  last_.role = after ? "master" : role_name(info.role);
  last_.master_node = info.master_node;
  last_.peer_node = info.peer_node;
  last_.cause = info.cause != nullptr ? info.cause : "";
  last_.since_ns = info.since_ns;
  if (after && !before) {
    const std::uint64_t s = info.since_ns / 1000000000u;
    const std::uint64_t age = s > kStrengthEpochS ? s - kStrengthEpochS : 0;
    master_strength_ = static_cast<std::int32_t>(std::clamp<std::uint64_t>(age, kMasterStrength, INT32_MAX));
  }
  return before != after;
}

std::int32_t PairRole::strength() const {
  const std::lock_guard lock(mutex_);
  return master_locked() ? master_strength_ : kStandbyStrength;
}

PairStatus PairRole::snapshot() const {
  const std::lock_guard lock(mutex_);
  PairStatus s = last_;
  s.node = node_;
  if (s.role.empty() && node_ != 0) s.role = "undecided";
  return s;
}

}  // namespace cobridge::dds
