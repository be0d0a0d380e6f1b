// FastscanPlan: what a CiA 305 Fastscan knows before it starts, and the
// order in which it guesses.
//
// A Fastscan settles the four address fields of one non-configured slave in
// turn (vendor, product, revision, serial). A field can be searched bit by
// bit (32 exchanges; every bit that is 1 leaves one exchange unanswered, and
// silence costs a timeout) or confirmed whole with BitChecked 0 (one
// exchange; a wrong guess costs one timeout). Identities known in advance
// (configured devices, the remembered table, the models the configuration
// names) make guesses far cheaper than searches.
//
// CiA 305: a slave whose field does not match a confirm stays on that field
// (its LSSPos is unchanged), so another value can be tried for the same field
// in the same scan, and only the slaves that matched go on.
//
// A plan holds up to kMaxTargets identities, each field known or not. The
// candidates for the field being settled are the known values of that field
// among the targets consistent with the fields settled so far; the value
// shared by the most targets is tried first (the fewest expected timeouts:
// one confirm decides for all of them). When no candidate is answered, the
// field is searched bit by bit if a consistent target leaves it unknown or
// `search_unknown` is set; otherwise the scan ends with "not found" (no such
// slave is non-configured), at the cost of one timeout.
//
// Thread: a value type; no allocation, no clock. Used by LssMaster on its
// thread.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>

#include "canopen/lss.hpp"

namespace cobridge::canopen {

// One identity, each field (in LssField order) known or not.
struct FastscanTarget {
  std::array<std::optional<uint32_t>, kLssFieldCount> field{};

  [[nodiscard]] static FastscanTarget of(std::optional<uint32_t> vendor, std::optional<uint32_t> product,
                                         std::optional<uint32_t> revision,
                                         std::optional<uint32_t> serial) noexcept {
    return FastscanTarget{{vendor, product, revision, serial}};
  }
  // True when every field before `upto` is unknown here or equals `settled`'s.
  [[nodiscard]] bool consistent(const LssAddress& settled, uint8_t upto) const noexcept;
};

class FastscanPlan {
 public:
  // 32 configured devices, each with its serial and a guessed revision
  // beside the unknown one (FastscanKnowledge).
  static constexpr std::size_t kMaxTargets = 64;
  // Which targets' values were tried for the field being settled (bit i = target i).
  using Tried = uint64_t;

  // Adds a target. A full plan sets search_unknown instead (still finds every
  // slave, only slower) and returns false. Duplicates are kept once.
  bool add(const FastscanTarget& t) noexcept;

  // The next value to confirm for `field`, given the fields settled before it;
  // marks every target with that value as tried. nullopt = no candidate left.
  [[nodiscard]] std::optional<uint32_t> next_candidate(const LssAddress& settled, uint8_t field,
                                                       Tried& tried) const noexcept;
  // After every candidate failed: may the field be searched bit by bit?
  [[nodiscard]] bool may_search(const LssAddress& settled, uint8_t field) const noexcept;

  [[nodiscard]] std::size_t size() const noexcept { return count_; }
  [[nodiscard]] const FastscanTarget& target(std::size_t i) const noexcept { return targets_[i]; }

  // Search what no target names (a general scan: strangers too).
  bool search_unknown = false;

 private:
  std::array<FastscanTarget, kMaxTargets> targets_{};
  std::size_t count_ = 0;
};

}  // namespace cobridge::canopen
