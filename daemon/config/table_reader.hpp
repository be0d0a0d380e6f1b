// TableReader (private to the config layer): reads the values of one TOML
// table against its schema and turns every problem into a Diagnostic with
// the position toml++ recorded: the value's position for a bad value, the
// key's for an unknown key, the table header's for a missing key. Messages
// start with the context ("bus \"line1\": ") and use the key's dotted path
// inside the section ("tpdo1.event_timer_ms").
//
// Thread contract: used by the loader on its calling thread only.
#pragma once

#include "config/diagnostic.hpp"

#include <toml++/toml.h>

#include <cstdint>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace cobridge::config {

// Collects diagnostics for one file.
class DiagnosticSink {
 public:
  explicit DiagnosticSink(std::string file) : file_(std::move(file)) {}
  void add(const toml::source_position& where, std::string message);
  void add(std::uint32_t line, std::uint32_t column, std::string message);
  [[nodiscard]] const std::string& file() const noexcept { return file_; }
  [[nodiscard]] bool empty() const noexcept { return diagnostics_.empty(); }
  [[nodiscard]] std::vector<Diagnostic> take_sorted();

 private:
  std::string file_;
  std::vector<Diagnostic> diagnostics_;
};

// "integer", "string", ...: the TOML type names used in messages.
[[nodiscard]] std::string_view type_name(toml::node_type type) noexcept;
// "a, b, c"
[[nodiscard]] std::string join(std::initializer_list<std::string_view> names);
[[nodiscard]] std::string in_quotes(std::string_view s);

template <class E>
struct Choice {
  std::string_view name;
  E value;
};

class TableReader {
 public:
  // `header` names the section in unknown-key messages ("[[bus]]"),
  // `context` prefixes every message, `prefix` is prepended to key names.
  TableReader(const toml::table& table, std::string header, std::string context, std::string prefix,
              DiagnosticSink& sink)
      : table_(table), header_(std::move(header)), context_(std::move(context)), prefix_(std::move(prefix)),
        sink_(sink) {}

  // Reports every key that is not in `allowed`.
  void check_keys(std::initializer_list<std::string_view> allowed);

  [[nodiscard]] const toml::node* find(std::string_view key) const noexcept;
  [[nodiscard]] const toml::table& table() const noexcept { return table_; }
  [[nodiscard]] const std::string& context() const noexcept { return context_; }
  [[nodiscard]] std::string path(std::string_view key) const { return prefix_ + std::string(key); }

  // Each returns nothing (and reports why) if the key is there but wrong;
  // nothing (silently) if the key is absent.
  [[nodiscard]] std::optional<std::int64_t> integer(std::string_view key, std::int64_t min, std::int64_t max);
  [[nodiscard]] std::optional<std::int64_t> integer_in(std::string_view key,
                                                       std::initializer_list<std::int64_t> allowed);
  // An integer or a float (2, 0.5), within [min, max].
  [[nodiscard]] std::optional<double> number(std::string_view key, double min, double max);
  [[nodiscard]] std::optional<std::string> string(std::string_view key);
  [[nodiscard]] std::optional<bool> boolean(std::string_view key);
  [[nodiscard]] const toml::table* subtable(std::string_view key);
  [[nodiscard]] const toml::array* array(std::string_view key);

  template <class E>
  [[nodiscard]] std::optional<E> choice(std::string_view key, std::initializer_list<Choice<E>> choices) {
    const auto s = string(key);
    if (!s) return std::nullopt;
    for (const auto& c : choices) {
      if (c.name == *s) return c.value;
    }
    std::string allowed;
    for (const auto& c : choices) {
      if (!allowed.empty()) allowed += ", ";
      allowed += c.name;
    }
    error(*find(key), path(key) + " " + in_quotes(*s) + " is not allowed (allowed: " + allowed + ")");
    return std::nullopt;
  }

  // Reports `key` as missing, at the table header.
  void missing(std::string_view key);
  // Reports a problem with `node`, prefixed with the context.
  void error(const toml::node& node, const std::string& message);
  // Reports a wrong type for `node`.
  void wrong_type(const toml::node& node, std::string_view what, std::string_view expected);

 private:
  const toml::table& table_;
  std::string header_;
  std::string context_;
  std::string prefix_;
  DiagnosticSink& sink_;
};

}  // namespace cobridge::config
