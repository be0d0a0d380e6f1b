// The FamilyTraits of every family (traits.hpp), in a table indexed by
// FamilyId: `traits(id)` is a constant-time lookup usable in constant
// expressions. A FamilyId without an entry fails the static_asserts below
// and the exhaustive switch in `family_index`.
//
// Thread contract: constants; any thread.
#pragma once

#include <array>
#include <cstddef>
#include <limits>

#include "families/ifm_rm.hpp"
#include "families/novotechnik_multiturn.hpp"
#include "families/novotechnik_rotary.hpp"
#include "families/traits.hpp"

namespace cobridge::families {

inline constexpr std::size_t kNotAFamily = std::numeric_limits<std::size_t>::max();

// The position of `id` in kFamilyTraits; kNotAFamily for a value that names
// no family. A switch without `default`: -Wswitch names it when FamilyId
// gains an enumerator.
[[nodiscard]] constexpr std::size_t family_index(FamilyId id) noexcept {
  switch (id) {
    case FamilyId::novotechnik_rotary: return 0;
    case FamilyId::novotechnik_multiturn: return 1;
    case FamilyId::ifm_rm: return 2;
  }
  return kNotAFamily;
}

inline constexpr std::array<FamilyTraits, 3> kFamilyTraits{
    kNovotechnikRotaryTraits,
    kNovotechnikMultiturnTraits,
    kIfmRmTraits,
};

[[nodiscard]] constexpr bool traits_table_is_complete() noexcept {
  // Every entry sits at its family's index ...
  for (std::size_t i = 0; i < kFamilyTraits.size(); ++i) {
    if (family_index(kFamilyTraits[i].id) != i) return false;
  }
  // ... and every value of the enum's type that family_index knows has one.
  for (unsigned v = 0; v <= std::numeric_limits<std::uint8_t>::max(); ++v) {
    const std::size_t i = family_index(static_cast<FamilyId>(v));
    if (i != kNotAFamily && i >= kFamilyTraits.size()) return false;
  }
  return true;
}
static_assert(traits_table_is_complete(), "kFamilyTraits: one entry per FamilyId, in family_index order");

[[nodiscard]] constexpr const FamilyTraits& traits(FamilyId id) noexcept { return kFamilyTraits[family_index(id)]; }

}  // namespace cobridge::families
