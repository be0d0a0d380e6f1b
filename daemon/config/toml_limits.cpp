#include "config/toml_limits.hpp"

namespace cobridge::config {

namespace {

// Where the scan is: outside any string, or inside one of TOML's four kinds.
enum class Mode : std::uint8_t { code, comment, basic, literal, multi_basic, multi_literal };

struct Cursor {
  std::string_view text;
  std::size_t i = 0;
  std::uint32_t line = 1;
  std::uint32_t column = 1;

  [[nodiscard]] bool starts(std::string_view s) const noexcept { return text.substr(i, s.size()) == s; }
  void advance(std::size_t n = 1) noexcept {
    for (std::size_t k = 0; k < n && i < text.size(); ++k, ++i) {
      if (text[i] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
  }
};

// One step outside strings and comments; returns the new mode.
Mode step_code(Cursor& c, std::size_t& depth) {
  const char ch = c.text[c.i];
  if (ch == '#') return Mode::comment;
  if (c.starts("\"\"\"")) {
    c.advance(2);
    return Mode::multi_basic;
  }
  if (c.starts("'''")) {
    c.advance(2);
    return Mode::multi_literal;
  }
  if (ch == '"') return Mode::basic;
  if (ch == '\'') return Mode::literal;
  if (ch == '[' || ch == '{') ++depth;
  if ((ch == ']' || ch == '}') && depth > 0) --depth;
  return Mode::code;
}

// One step inside a string or comment; returns the mode after it.
Mode step_string(Cursor& c, Mode mode) {
  const char ch = c.text[c.i];
  switch (mode) {
    case Mode::comment: return ch == '\n' ? Mode::code : mode;
    case Mode::basic:
      if (ch == '\\') c.advance();  // the escaped character is not a quote
      return ch == '"' || ch == '\n' ? Mode::code : mode;
    case Mode::literal: return ch == '\'' || ch == '\n' ? Mode::code : mode;
    case Mode::multi_basic:
      if (ch == '\\') {
        c.advance();
        return mode;
      }
      if (c.starts("\"\"\"")) {
        c.advance(2);
        return Mode::code;
      }
      return mode;
    case Mode::multi_literal:
      if (c.starts("'''")) {
        c.advance(2);
        return Mode::code;
      }
      return mode;
    case Mode::code: break;
  }
  return mode;
}

}  // namespace

std::optional<TomlLimitViolation> check_toml_limits(std::string_view text, std::size_t max_bytes,
                                                    std::size_t max_depth) {
  if (text.size() > max_bytes)
    return TomlLimitViolation{0, 0, "the file is " + std::to_string(text.size()) + " bytes; a configuration may have at most " +
                                        std::to_string(max_bytes)};
  Cursor c{text};
  Mode mode = Mode::code;
  std::size_t depth = 0;
  while (c.i < text.size()) {
    const std::uint32_t line = c.line;
    const std::uint32_t column = c.column;
    mode = mode == Mode::code ? step_code(c, depth) : step_string(c, mode);
    if (depth > max_depth)
      return TomlLimitViolation{line, column, "arrays and inline tables nested more than " + std::to_string(max_depth) +
                                                  " levels deep"};
    c.advance();
  }
  return std::nullopt;
}

}  // namespace cobridge::config
