#include "canopen/fastscan_plan.hpp"

namespace cobridge::canopen {

bool FastscanTarget::consistent(const LssAddress& settled, uint8_t upto) const noexcept {
  for (uint8_t f = 0; f < upto && f < kLssFieldCount; ++f)
    if (field[f] && *field[f] != settled.field(static_cast<LssField>(f))) return false;
  return true;
}

bool FastscanPlan::add(const FastscanTarget& t) noexcept {
  for (std::size_t i = 0; i < count_; ++i)
    if (targets_[i].field == t.field) return true;
  if (count_ == kMaxTargets) {
    search_unknown = true;
    return false;
  }
  targets_[count_++] = t;
  return true;
}

std::optional<uint32_t> FastscanPlan::next_candidate(const LssAddress& settled, uint8_t field,
                                                     Tried& tried) const noexcept {
  // The value most untried consistent targets share; ties go to the earlier
  // target (the caller lists what it expects most first). n <= 64: the
  // quadratic count costs nothing next to one CAN exchange.
  std::optional<uint32_t> best;
  std::size_t best_count = 0;
  for (std::size_t i = 0; i < count_; ++i) {
    const auto& v = targets_[i].field[field];
    if (!v || (tried & (Tried{1} << i)) || !targets_[i].consistent(settled, field)) continue;
    std::size_t n = 0;
    for (std::size_t j = 0; j < count_; ++j)
      if (!(tried & (Tried{1} << j)) && targets_[j].field[field] == v && targets_[j].consistent(settled, field)) ++n;
    if (n > best_count) {
      best = v;
      best_count = n;
    }
  }
  if (!best) return std::nullopt;
  for (std::size_t i = 0; i < count_; ++i)
    if (targets_[i].field[field] == best) tried |= Tried{1} << i;
  return best;
}

bool FastscanPlan::may_search(const LssAddress& settled, uint8_t field) const noexcept {
  if (search_unknown) return true;
  for (std::size_t i = 0; i < count_; ++i)
    if (!targets_[i].field[field] && targets_[i].consistent(settled, field)) return true;
  return false;
}

}  // namespace cobridge::canopen
