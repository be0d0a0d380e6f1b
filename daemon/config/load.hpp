// Loading the configuration file: parse the TOML text, check it against the
// schema of docs/configuration.md, apply defaults and cross-check names,
// node-IDs, serial numbers and EDS paths. All problems are collected, not
// just the first, each with its file:line:column.
//
// Nothing here throws, whatever the input (garbage, truncation, a file that
// cannot be read): failures come back as diagnostics.
//
// Thread contract: called on the start-up / reload thread (file I/O and
// allocation); no shared state, so concurrent calls are safe.
#pragma once

#include "config/config.hpp"
#include "config/diagnostic.hpp"

#include <filesystem>
#include <string_view>
#include <variant>
#include <vector>

namespace cobridge::config {

// Either a valid Config or the (non-empty) list of what is wrong, sorted by
// line and column.
class LoadResult {
 public:
  explicit LoadResult(Config config) noexcept : value_(std::move(config)) {}
  explicit LoadResult(std::vector<Diagnostic> diagnostics) noexcept : value_(std::move(diagnostics)) {}

  [[nodiscard]] bool ok() const noexcept { return std::holds_alternative<Config>(value_); }
  explicit operator bool() const noexcept { return ok(); }

  // Precondition: ok().
  [[nodiscard]] const Config& config() const& { return std::get<Config>(value_); }
  [[nodiscard]] Config&& config() && { return std::get<Config>(std::move(value_)); }

  // Empty when ok().
  [[nodiscard]] const std::vector<Diagnostic>& diagnostics() const noexcept {
    static const std::vector<Diagnostic> none;
    const auto* d = std::get_if<std::vector<Diagnostic>>(&value_);
    return d != nullptr ? *d : none;
  }

 private:
  std::variant<Config, std::vector<Diagnostic>> value_;
};

// Loads `path`. Relative paths inside the file (eds, device_dirs) are taken
// relative to the file's directory. Diagnostics name the file as `path` was
// given.
[[nodiscard]] LoadResult load(const std::filesystem::path& path) noexcept;

// Loads TOML text; `file_name` is used in diagnostics, `base_dir` resolves
// relative paths (empty = the current directory).
[[nodiscard]] LoadResult load_string(std::string_view text, std::string_view file_name,
                                     const std::filesystem::path& base_dir = {}) noexcept;

}  // namespace cobridge::config
