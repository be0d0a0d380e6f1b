// plugin::Error: the one shape of a failure inside a plugin (configuration,
// start-up), the plugin-side counterpart of the daemon's Error. A plugin sees
// only this SDK, and the daemon learns of a plugin's failure as the text the
// plugin copies into its `err` buffer (plugin.h), so this carries what that
// text needs and what a plugin's own tests check:
//   - code: the precise cause (a configuration error, errno, a DDS return
//     code); empty = success;
//   - message: what is wrong and what is allowed, ready for the err text;
//   - where: the place it concerns (a key, a file), empty when the message
//     already says it.
// Errors are values, not exceptions; the plugin decides whether to log.
// ConfigErrc is the precise code of a configuration error, one set for every
// plugin's [outputs.<name>] table. Header-only.
//
// Thread contract: plain value type; any thread.
#pragma once

#include <string>
#include <system_error>
#include <utility>

namespace cobridge::plugin {

enum class ConfigErrc : int {
  kOk = 0,
  kSyntax = 1,      // not TOML
  kUnknownKey = 2,  // a key the plugin does not know
  kWrongType = 3,   // a key with a value of the wrong TOML type
  kOutOfRange = 4,  // a value outside its range or set
  kMissingKey = 5,  // a key required with others is absent
  kBadFile = 6,     // a file named by a key cannot be used (missing, unreadable, open to others)
  // The names the Modbus plugin's configuration reads better with.
  kBadType = kWrongType,
  kBadValue = kOutOfRange,
};

namespace detail {
class ConfigCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "cobridge.plugin.config"; }
  std::string message(int c) const override {
    switch (static_cast<ConfigErrc>(c)) {
      case ConfigErrc::kOk: return "ok";
      case ConfigErrc::kSyntax: return "not valid TOML";
      case ConfigErrc::kUnknownKey: return "unknown key";
      case ConfigErrc::kWrongType: return "wrong value type";
      case ConfigErrc::kOutOfRange: return "value out of range";
      case ConfigErrc::kMissingKey: return "required key missing";
      case ConfigErrc::kBadFile: return "file cannot be used";
    }
    return "unknown error";
  }
};
}  // namespace detail

[[nodiscard]] inline const std::error_category& config_category() noexcept {
  static const detail::ConfigCategory category;
  return category;
}
[[nodiscard]] inline std::error_code make_error_code(ConfigErrc e) noexcept {
  return {static_cast<int>(e), config_category()};
}

struct Error {
  std::error_code code;
  std::string message;
  std::string where;

  Error() = default;
  Error(std::error_code precise, std::string msg, std::string place = {})
      : code(precise), message(std::move(msg)), where(std::move(place)) {}

  [[nodiscard]] bool ok() const noexcept { return !code; }
  explicit operator bool() const noexcept { return static_cast<bool>(code); }  // true = failed, like the daemon's

  // "where: message" (just "message" when where is empty).
  [[nodiscard]] std::string to_string() const { return where.empty() ? message : where + ": " + message; }
};

}  // namespace cobridge::plugin

template <>
struct std::is_error_code_enum<cobridge::plugin::ConfigErrc> : std::true_type {};
