#include "config/toml_limits.hpp"

#include <vector>

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

// What the scan expects next outside strings and comments.
enum class Expect : std::uint8_t {
  key,     // at a line's start, or in an inline table after '{' or ','
  header,  // the key of a table header, after '[' or '[['
  value,   // after '=', or in an array after '[' or ','
  rest,    // after a value or a header: ',', a closing bracket, the line's end
};

// An array or inline table not closed yet, and its level.
struct Open {
  bool table = false;
  std::size_t level = 0;
};

// The nesting where the scan is, in the levels of toml_limits.hpp. Garbage
// (a '[' where no value may be) still nests one level per bracket: toml++
// stops at the first syntax error, but what it built before must be shallow.
class Shape {
 public:
  explicit Shape(std::size_t max_depth) : max_(max_depth) {}

  // One character outside strings and comments, or a line end that closed one.
  void step(Cursor& c);
  // What went deeper than the limit ("key", ...), nullptr while within it.
  [[nodiscard]] const char* too_deep() const noexcept { return too_deep_; }

 private:
  void start_header(Cursor& c);
  void end_line();
  void open(bool table);
  void close();
  void next_item();
  void deeper();
  void expect_key(std::size_t level);
  void expect_value(std::size_t level);
  bool check(std::size_t level, const char* what);

  std::size_t max_;
  std::vector<Open> open_;        // levels rise along it, so it holds at most max_
  std::size_t header_level_ = 0;  // the last table header's; its keys are one below
  Expect expect_ = Expect::key;
  bool line_start_ = true;        // at the top level, nothing but blanks yet on the line
  bool key_started_ = false;      // the key being expected has begun
  std::size_t key_level_ = 1;     // the level of the key (or header) segment being read
  std::size_t value_level_ = 1;   // the level an array or inline table opened now gets
  const char* too_deep_ = nullptr;
};

void Shape::step(Cursor& c) {
  const char ch = c.text[c.i];
  if (ch == '\n') return end_line();
  if (ch == ' ' || ch == '\t' || ch == '\r' || ch == '#') return;
  const bool first = line_start_;
  line_start_ = false;
  const bool structural = ch == '[' || ch == ']' || ch == '{' || ch == '}' || ch == ',' || ch == '=';
  if (expect_ == Expect::key && !key_started_ && !structural) {
    key_started_ = true;  // a bare or quoted key's first segment
    if (!check(key_level_, "key")) return;
  }
  switch (ch) {
    case '[':
      if (first && expect_ == Expect::key && open_.empty()) return start_header(c);
      return open(false);
    case '{': return open(true);
    case ']':
      if (open_.empty() && expect_ == Expect::header) {
        header_level_ = key_level_;
        expect_ = Expect::rest;
        return;
      }
      return close();
    case '}': return close();
    case ',': return next_item();
    case '.': return deeper();
    case '=':
      if (expect_ == Expect::key) expect_value(key_level_);  // a key's array or table is at its level
      return;
    default: return;
  }
}

// '[' or '[[' first on a line: the element of an array of tables is one
// level below the array the header names.
void Shape::start_header(Cursor& c) {
  const bool array = c.starts("[[");
  if (array) c.advance();
  expect_ = Expect::header;
  key_level_ = array ? 2 : 1;
  (void)check(key_level_, "table header");
}

void Shape::end_line() {
  if (!open_.empty()) return;  // arrays span lines
  line_start_ = true;
  expect_key(header_level_ + 1);
}

void Shape::open(bool table) {
  const std::size_t inner = (open_.empty() ? header_level_ : open_.back().level) + 1;
  const std::size_t level = expect_ == Expect::value ? value_level_ : inner;
  if (!check(level, "arrays and inline tables")) return;
  open_.push_back(Open{table, level});
  if (table) {
    expect_key(level + 1);
  } else {
    expect_value(level + 1);
  }
}

void Shape::close() {
  if (open_.empty()) return;  // stray, or the second ']' of '[[a]]'
  open_.pop_back();
  expect_ = Expect::rest;
}

void Shape::next_item() {
  if (open_.empty()) return;
  const Open& o = open_.back();
  if (o.table) {
    expect_key(o.level + 1);
  } else {
    expect_value(o.level + 1);
  }
}

// A dot separates key segments; in a value it is a float's or a time's.
void Shape::deeper() {
  if (expect_ == Expect::header) {
    (void)check(++key_level_, "table header");
  } else if (expect_ == Expect::key) {
    (void)check(++key_level_, "key");
  }
}

void Shape::expect_key(std::size_t level) {
  expect_ = Expect::key;
  key_started_ = false;
  key_level_ = level;
}

void Shape::expect_value(std::size_t level) {
  expect_ = Expect::value;
  value_level_ = level;
}

bool Shape::check(std::size_t level, const char* what) {
  if (level <= max_) return true;
  if (too_deep_ == nullptr) too_deep_ = what;
  return false;
}

// One step outside strings and comments; returns the new mode.
Mode step_code(Cursor& c, Shape& shape) {
  const char ch = c.text[c.i];
  shape.step(c);
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
  return Mode::code;
}

// Comments and one-line strings end at the line's end (which the shape must see).
bool ends_at_line_end(Mode mode) { return mode == Mode::comment || mode == Mode::basic || mode == Mode::literal; }

// The closing quotes of a multi-line string: TOML lets one or two quotes
// right before them belong to the string ("""a""""" is a""), so the whole
// run closes it, and none of it opens another string.
Mode close_multi_line(Cursor& c, char quote) {
  std::size_t run = 0;
  while (c.i + run < c.text.size() && c.text[c.i + run] == quote) ++run;
  c.advance(run - 1);
  return Mode::code;
}

// One step inside a string or comment (never at the line end that closes
// one); returns the mode after it.
Mode step_string(Cursor& c, Mode mode) {
  const char ch = c.text[c.i];
  const bool escape = ch == '\\' && c.i + 1 < c.text.size() && c.text[c.i + 1] != '\n';
  switch (mode) {
    case Mode::comment: return mode;
    case Mode::basic:
      if (escape) c.advance();  // the escaped character is not a quote
      return ch == '"' ? Mode::code : mode;
    case Mode::literal: return ch == '\'' ? Mode::code : mode;
    case Mode::multi_basic:
      if (ch == '\\') {
        c.advance();
        return mode;
      }
      if (c.starts("\"\"\"")) return close_multi_line(c, '"');
      return mode;
    case Mode::multi_literal:
      if (c.starts("'''")) return close_multi_line(c, '\'');
      return mode;
    case Mode::code: break;
  }
  return mode;
}

TomlLimitViolation too_deep(std::uint32_t line, std::uint32_t column, const char* what, std::size_t max_depth) {
  const std::string n = std::to_string(max_depth);
  return TomlLimitViolation{line, column, std::string(what) + " nested more than " + n + " levels deep (at most " +
                                              n + ": one level per segment of a table header or key, one per "
                                              "array or inline table)"};
}

}  // namespace

std::optional<TomlLimitViolation> check_toml_limits(std::string_view text, std::size_t max_bytes,
                                                    std::size_t max_depth) {
  if (text.size() > max_bytes)
    return TomlLimitViolation{0, 0, "the file is " + std::to_string(text.size()) + " bytes; a configuration may have at most " +
                                        std::to_string(max_bytes)};
  Cursor c{text};
  Shape shape(max_depth);
  Mode mode = Mode::code;
  while (c.i < text.size()) {
    const std::uint32_t line = c.line;
    const std::uint32_t column = c.column;
    if (text[c.i] == '\n' && ends_at_line_end(mode)) mode = Mode::code;
    mode = mode == Mode::code ? step_code(c, shape) : step_string(c, mode);
    if (shape.too_deep() != nullptr) return too_deep(line, column, shape.too_deep(), max_depth);
    c.advance();
  }
  return std::nullopt;
}

}  // namespace cobridge::config
