#include "config/table_reader.hpp"

#include <algorithm>
#include <cstdio>

namespace cobridge::config {
namespace {

// Levenshtein distance, for "did you mean" on misspelt keys (short strings).
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + cost});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// The value under `key` as a T (toml++'s node::as<T>), or nullptr: silently
// when the key is absent, reported as a wrong type when it holds another type.
template <class T>
auto typed(TableReader& r, std::string_view key, std::string_view expected) {
  const toml::node* n = r.find(key);
  const auto* v = n != nullptr ? n->as<T>() : nullptr;
  if (n != nullptr && v == nullptr) r.wrong_type(*n, r.path(key), expected);
  return v;
}

}  // namespace

void DiagnosticSink::add(const toml::source_position& where, std::string message) {
  add(where.line, where.column, std::move(message));
}

void DiagnosticSink::add(std::uint32_t line, std::uint32_t column, std::string message) {
  diagnostics_.push_back(Diagnostic{file_, line, column, std::move(message)});
}

std::vector<Diagnostic> DiagnosticSink::take_sorted() {
  // File order reads best; problems found in a later pass (duplicates)
  // then appear next to the line they concern.
  std::stable_sort(diagnostics_.begin(), diagnostics_.end(), [](const Diagnostic& a, const Diagnostic& b) {
    return a.line != b.line ? a.line < b.line : a.column < b.column;
  });
  return std::move(diagnostics_);
}

std::string_view type_name(toml::node_type type) noexcept {
  switch (type) {
    case toml::node_type::table: return "table";
    case toml::node_type::array: return "array";
    case toml::node_type::string: return "string";
    case toml::node_type::integer: return "integer";
    case toml::node_type::floating_point: return "float";
    case toml::node_type::boolean: return "boolean";
    case toml::node_type::date: return "date";
    case toml::node_type::time: return "time";
    case toml::node_type::date_time: return "date-time";
    case toml::node_type::none: break;
  }
  return "nothing";
}

std::string join(std::initializer_list<std::string_view> names) {
  std::string out;
  for (const auto n : names) {
    if (!out.empty()) out += ", ";
    out += n;
  }
  return out;
}

std::string in_quotes(std::string_view s) {
  std::string out = "\"";
  for (const char c : s) {
    // Keep messages on one line and printable whatever the file holds.
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (u < 0x20 || u == 0x7F) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02X", static_cast<unsigned>(u));
      out += buf;
    } else {
      out += c;
    }
  }
  out += '"';
  return out;
}

void TableReader::check_keys(std::initializer_list<std::string_view> allowed) {
  for (auto&& [key, value] : table_) {
    const std::string_view k = key.str();
    if (std::find(allowed.begin(), allowed.end(), k) != allowed.end()) continue;
    std::string message = context_ + "unknown key " + in_quotes(k) + " in " + header_ + " (allowed: " + join(allowed) + ")";
    std::string_view best;
    std::size_t best_distance = 3;  // suggest only close matches
    for (const auto a : allowed) {
      // A key missing its unit suffix ("event_timer") is a near miss too.
      const bool prefix = k.size() >= 4 && a.size() > k.size() && a.substr(0, k.size()) == k;
      const std::size_t d = prefix ? 1 : edit_distance(k, a);
      if (d < best_distance) {
        best_distance = d;
        best = a;
      }
    }
    if (!best.empty()) message += "; did you mean " + in_quotes(best) + "?";
    sink_.add(key.source().begin, std::move(message));
  }
}

const toml::node* TableReader::find(std::string_view key) const noexcept { return table_.get(key); }

std::optional<std::int64_t> TableReader::integer(std::string_view key, std::int64_t min, std::int64_t max) {
  const auto* v = typed<std::int64_t>(*this, key, "an integer");
  if (v == nullptr) return std::nullopt;
  const std::int64_t x = v->get();
  if (x < min || x > max) {
    error(*v, path(key) + " " + std::to_string(x) + " is out of range (allowed: " + std::to_string(min) + ".." +
                  std::to_string(max) + ")");
    return std::nullopt;
  }
  return x;
}

std::optional<double> TableReader::number(std::string_view key, double min, double max) {
  const toml::node* n = find(key);
  if (n == nullptr) return std::nullopt;
  double x = 0;
  if (const auto* i = n->as_integer()) {
    x = static_cast<double>(i->get());
  } else if (const auto* f = n->as_floating_point()) {
    x = f->get();
  } else {
    wrong_type(*n, path(key), "a number");
    return std::nullopt;
  }
  if (!(x >= min && x <= max)) {  // NaN too
    char text[96];
    std::snprintf(text, sizeof text, " %g is out of range (allowed: %g..%g)", x, min, max);
    error(*n, path(key) + text);
    return std::nullopt;
  }
  return x;
}

std::optional<std::int64_t> TableReader::integer_in(std::string_view key, std::initializer_list<std::int64_t> allowed) {
  const auto* v = typed<std::int64_t>(*this, key, "an integer");
  if (v == nullptr) return std::nullopt;
  const std::int64_t x = v->get();
  if (std::find(allowed.begin(), allowed.end(), x) != allowed.end()) return x;
  std::string list;
  for (const auto a : allowed) {
    if (!list.empty()) list += ", ";
    list += std::to_string(a);
  }
  error(*v, path(key) + " " + std::to_string(x) + " is not allowed (allowed: " + list + ")");
  return std::nullopt;
}

std::optional<std::string> TableReader::string(std::string_view key) {
  const auto* v = typed<std::string>(*this, key, "a string");
  if (v == nullptr) return std::nullopt;
  return v->get();
}

std::optional<bool> TableReader::boolean(std::string_view key) {
  const auto* v = typed<bool>(*this, key, "a boolean");
  if (v == nullptr) return std::nullopt;
  return v->get();
}

const toml::table* TableReader::subtable(std::string_view key) {
  return typed<toml::table>(*this, key, "a table");
}

const toml::array* TableReader::array(std::string_view key) {
  return typed<toml::array>(*this, key, "an array");
}

void TableReader::missing(std::string_view key) {
  sink_.add(table_.source().begin, context_ + "missing required key " + in_quotes(path(key)) + " in " + header_);
}

void TableReader::error(const toml::node& node, const std::string& message) {
  sink_.add(node.source().begin, context_ + message);
}

void TableReader::wrong_type(const toml::node& node, std::string_view what, std::string_view expected) {
  error(node, std::string(what) + " must be " + std::string(expected) + ", got " + std::string(type_name(node.type())));
}

}  // namespace cobridge::config
