// Known models: the encoder models a [[device]] may name with `model = "..."`,
// with the facts the configuration checks need (vendor, product codes,
// channels, CAM count, which filters exist). The facts are the device
// families' (daemon/families/, one file pair per manual); this is
// their view in the configuration's terms.
//
// Thread contract: a table built once on first use (thread-safe static);
// any thread.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

#include "families/family.hpp"

namespace cobridge::config {

struct KnownModel {
  std::string_view name;
  families::FamilyId family;  // the family's module: families::family(id)
  std::uint32_t vendor;
  // Product codes (0x1018/2) the model may report; empty = not checkable
  // (ifm prints an ambiguous product code, F§7.3).
  std::span<const std::uint32_t> products;
  std::uint8_t max_channels;      // position channels
  std::uint8_t cams_per_channel;  // CAMs 1..n per channel
  bool position_filter;           // moving average configurable
  bool speed_filter;              // separate speed filter (E 0x2010/2)
};

[[nodiscard]] std::span<const KnownModel> known_models() noexcept;
// nullptr if `name` is not a known model (exact, case-sensitive match).
[[nodiscard]] const KnownModel* find_model(std::string_view name) noexcept;

}  // namespace cobridge::config
