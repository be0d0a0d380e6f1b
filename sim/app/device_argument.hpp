// DeviceArgument: the text of one `--device MODEL[:key=value,...]` argument of
// cobridge-sim, parsed into a sim::DeviceSpec.
//
// The model table lives with SimDevice (sim_models.cpp); the parser is handed
// the lookup so that it can be tested without the device runtime. Keys:
// serial, node, channels, bitrate, lss, segmented, c6, fastscan, vendor,
// product, revision (another vendor's identity), assign (accept|refuse|ignore
// an LSS node-ID), motion. `motion` must be
// the last key: its value runs to the end of the argument because the motion
// grammar itself uses ':' and ','.
// Thread: start-up only (allocates, builds messages).
#pragma once

#include "base/result.hpp"
#include "device/sim_device.hpp"

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace cobridge::sim {

// find_model's signature; tests pass their own table.
using ModelLookup = const ModelInfo* (*)(std::string_view name) noexcept;

struct DeviceArgument {
  DeviceSpec spec;
  bool serial_given = false;  // false: cobridge-sim assigns one
};

// A failure (kInvalidArgument) has the argument as its where and a message
// that names the key and what is allowed.
[[nodiscard]] Result<DeviceArgument> parse_device_argument(std::string_view text, ModelLookup lookup);

// Bit rates a family's devices can be ordered with (J§1.2.2, E§3.1: 50..1000;
// F§7.4 0x3001: 20..1000), in kbit/s.
[[nodiscard]] std::span<const std::uint16_t> family_bit_rates(FamilyId family) noexcept;

[[nodiscard]] std::string_view to_string(LssProfile profile) noexcept;

}  // namespace cobridge::sim
