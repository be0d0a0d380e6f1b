// TomlLimits: what a configuration text may be before the TOML parser sees
// it. toml++ parses nested arrays and inline tables recursively, so a file
// nested 50 000 levels deep overflows the stack (`--check-config` crashed,
// and so did a running daemon on SIGHUP). This scan is iterative: it knows
// TOML's strings (basic, literal, and their multi-line forms) and comments
// well enough to count only the brackets and braces that nest values.
//
// Thread: any; pure function.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace cobridge::config {

inline constexpr std::size_t kMaxConfigBytes = 1u << 20;  // a real configuration is a few kB
inline constexpr std::size_t kMaxTomlDepth = 32;          // the deepest real one is 3 ([outputs.x] arrays)

struct TomlLimitViolation {
  std::uint32_t line = 0;    // 1-based; 0 for the whole file (size)
  std::uint32_t column = 0;
  std::string message;
};

[[nodiscard]] std::optional<TomlLimitViolation> check_toml_limits(std::string_view text,
                                                                  std::size_t max_bytes = kMaxConfigBytes,
                                                                  std::size_t max_depth = kMaxTomlDepth);

}  // namespace cobridge::config
