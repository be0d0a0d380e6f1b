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

namespace cobridge::config {

enum class Family : std::uint8_t {
  novotechnik_rotary,      // manual J: RFC-4800, RSA-3200, RFE-3200, RSX-7900, RFX-6900
  ifm_rm,                  // manual F: RM8xxx, RM9xxx
  novotechnik_multiturn,   // manual E: MZ1-2200, MC1-2800, MB1-3600
};

struct KnownModel {
  std::string_view name;
  Family family;
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
