// TomlLimits: what a configuration text may be before the TOML parser sees
// it. toml++ builds and walks its tables recursively, one call per level, so
// a file nested 50 000 levels deep overflows the stack (`--check-config`
// crashed, and so did a running daemon on SIGHUP), whatever form the nesting
// takes: arrays and inline tables (`a = [[[...]]]`), dotted
// keys (`a.a.a... = 1`), table headers (`[a.a...]`, `[[a.a...]]`) and dotted
// keys inside inline tables.
//
// So the text's nesting is counted before parsing, in levels: each segment
// of a table header or key is one (`[a.b]` is 2, `a.b.c = 1` is 3; a quoted
// segment is one, dots and all), an array of tables' element one more
// (`[[a]]` is 2), keys start below their table header (or inline table), a
// key's array or inline table value is at the key's level, and each array or
// inline table inside an array one level below it. The scan is iterative and
// knows TOML's strings (basic, literal, and their multi-line forms) and
// comments well enough to count only brackets, braces and dots that nest.
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
inline constexpr std::size_t kMaxTomlDepth = 32;          // the deepest real one is 4 (a [[device.cam]] key)

struct TomlLimitViolation {
  std::uint32_t line = 0;    // 1-based; 0 for the whole file (size)
  std::uint32_t column = 0;  // of the bracket, brace or dot one level too deep
  std::string message;
};

[[nodiscard]] std::optional<TomlLimitViolation> check_toml_limits(std::string_view text,
                                                                  std::size_t max_bytes = kMaxConfigBytes,
                                                                  std::size_t max_depth = kMaxTomlDepth);

}  // namespace cobridge::config
