// PairRole: this gateway's part in a hot-standby pair, as the DDS output
// presents it (docs/dds.md, "A hot-standby pair").
//
// Both gateways of a pair decode every frame and write the same instances
// (they share gateway_id) with EXCLUSIVE ownership; a subscriber's reader
// keeps the stronger writer's stream and falls over to the other by itself
// once the stronger one's liveliness lease runs out. The gateway that is
// master of at least one of its buses writes at kMasterStrength, every
// other at kStandbyStrength, so the stream a subscriber sees is the master's.
// A master's strength is the time it took the role (seconds since
// 2020-01-01, at least kMasterStrength): a newer master is always stronger
// than the one it replaces, so a reader switches at the new master's first
// sample instead of waiting for the old writer's lease to run out (the two
// machines' clocks need only agree to within the time between takeovers).
//
// Thread contract: update() on the dispatcher thread (on_role); snapshot()
// on the presence thread. Off the hot path: one mutex, rare calls.
#pragma once

#include <cobridge/plugin.h>

#include <array>
#include <cstdint>
#include <mutex>
#include <string>

namespace cobridge::dds {

inline constexpr std::int32_t kStandbyStrength = 1;
inline constexpr std::int32_t kMasterStrength = 2;  // the least a master writes with
inline constexpr std::uint64_t kStrengthEpochS = 1577836800;  // 2020-01-01T00:00:00Z

// What GatewayStatus says of the pair.
struct PairStatus {
  std::uint8_t node = 0;  // [redundancy] node_id, 0 = the gateway runs alone
  std::string role;       // "master", "standby", "undecided"; "" alone
  std::uint8_t master_node = 0;
  std::uint8_t peer_node = 0;
  std::string cause;
  std::uint64_t since_ns = 0;
  friend bool operator==(const PairStatus&, const PairStatus&) = default;
};

class PairRole {
 public:
  explicit PairRole(std::uint8_t node) : node_(node) {}

  // Records one bus's role; returns true when the writers' strength must
  // change (the gateway became master of its first bus, or of none).
  bool update(const cobridge_role_info& info);
  [[nodiscard]] std::int32_t strength() const;
  [[nodiscard]] PairStatus snapshot() const;
  [[nodiscard]] std::uint8_t node() const noexcept { return node_; }

 private:
  [[nodiscard]] bool master_locked() const noexcept;

  const std::uint8_t node_;
  mutable std::mutex mutex_;
  std::array<std::uint8_t, 256> roles_{};  // per bus index: enum cobridge_role
  std::int32_t master_strength_ = kMasterStrength;
  PairStatus last_;                        // of the latest change, any bus
};

}  // namespace cobridge::dds
