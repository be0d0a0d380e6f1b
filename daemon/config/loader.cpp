// The Loader's frame: the sections in order, paths, arrays of tables and
// entry names, and the syntax checks several sections share.
#include "config/loader.hpp"
#include "config/service_access_section.hpp"

#include "config/toml_limits.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <map>
#include <system_error>

namespace cobridge::config::detail {

// Names used as DDS keys, in logs and in control-socket commands: keep them
// to characters that need no quoting anywhere.
bool is_identifier(std::string_view s) {
  if (s.empty() || s.size() > 64) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' ||
           c == '.';
  });
}

// The kernel's rule (dev_valid_name): 1..15 bytes (IFNAMSIZ 16 with the
// NUL), not "." or "..", no '/', ':' or white space.
bool is_interface_name(std::string_view s) {
  if (s.empty() || s.size() > 15 || s == "." || s == "..") return false;
  return std::none_of(s.begin(), s.end(), [](char c) {
    const auto u = static_cast<unsigned char>(c);
    return c == '/' || c == ':' || u <= 0x20 || u == 0x7F;
  });
}

// "n" or "low-high", decimal, 1 <= low <= high <= 127.
std::optional<std::pair<unsigned, unsigned>> parse_range(std::string_view text) {
  auto number = [](std::string_view digits) -> std::optional<unsigned> {
    unsigned v = 0;
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), v);
    if (digits.empty() || ec != std::errc{} || end != digits.data() + digits.size()) return std::nullopt;
    return v;
  };
  const auto dash = text.find('-');
  const auto low = number(text.substr(0, dash));
  const auto high = dash == std::string_view::npos ? low : number(text.substr(dash + 1));
  if (!low || !high || *low < 1 || *high > 127 || *low > *high) return std::nullopt;
  return std::make_pair(*low, *high);
}

std::string host_name() {
  std::array<char, 256> buf{};
  if (::gethostname(buf.data(), buf.size() - 1) != 0 || buf[0] == '\0') return "cobridge";
  return buf.data();
}

SourceLocation location(const DiagnosticSink& sink, const toml::node& n) {
  return SourceLocation{sink.file(), n.source().begin.line, n.source().begin.column};
}

std::string at(const SourceLocation& l) { return std::to_string(l.line) + ":" + std::to_string(l.column); }

LoadResult Loader::run(std::string_view text) {
  // Before the parser, which recurses per nesting level.
  if (const auto v = check_toml_limits(text)) {
    sink_.add(v->line, v->column, v->message);
    return LoadResult(sink_.take_sorted());
  }
  toml::table root;
  try {
    root = toml::parse(text, std::string_view{sink_.file()});
  } catch (const toml::parse_error& e) {
    sink_.add(e.source().begin, "TOML syntax error: " + std::string(e.description()));
    return LoadResult(sink_.take_sorted());
  }
  TableReader top(root, "the top level", "", "", sink_);
  top.check_keys({"gateway", "logging", "bus", "device", "outputs", "web", "control", "ascii_gateway", "redundancy"});
  read_gateway(top);
  read_logging(top);
  read_tables(root, "bus", &Loader::read_bus);
  read_tables(root, "device", &Loader::read_device);
  read_outputs(top);
  read_web(top);
  read_service_access(top, sink_, config_.services);
  read_redundancy(top);
  cross_check();
  check_redundancy_node();
  if (!sink_.empty()) return LoadResult(sink_.take_sorted());
  config_.source = sink_.file();
  return LoadResult(std::move(config_));
}

fs::path Loader::resolve(const std::string& p) const {
  fs::path path(p);
  return path.is_absolute() || base_dir_.empty() ? path : base_dir_ / path;
}

// An absolute path, or nothing (reported).
std::optional<fs::path> Loader::absolute_path(TableReader& r, std::string_view key) {
  auto s = r.string(key);
  if (!s) return std::nullopt;
  if (s->empty() || (*s)[0] != '/') {
    r.error(*r.find(key), r.path(key) + " must be an absolute path, got " + in_quotes(*s));
    return std::nullopt;
  }
  return fs::path(*s);
}

void Loader::read_tables(const toml::table& root, const char* key, void (Loader::*read)(const toml::table&)) {
  const toml::node* n = root.get(key);
  if (n == nullptr) return;
  const auto* arr = n->as_array();
  if (arr == nullptr || !arr->is_array_of_tables()) {
    sink_.add(n->source().begin, std::string(key) + " must be an array of tables ([[" + key + "]]), got " +
                                     std::string(type_name(n->type())));
    if (arr == nullptr) return;
  }
  for (const toml::node& e : *arr) {
    const auto* t = e.as_table();
    if (t == nullptr) continue;
    (this->*read)(*t);
  }
}

// The prefix of every message about one [[bus]] or [[device]] entry: its
// name once it is a string ("bus \"line1\": "), else its position ("bus #2: ").
std::string Loader::entry_context(std::string_view what, std::size_t ordinal, const toml::node* name_node) {
  if (name_node != nullptr && name_node->is_string()) {
    return std::string(what) + " " + in_quotes(name_node->as_string()->get()) + ": ";
  }
  return std::string(what) + " #" + std::to_string(ordinal) + ": ";
}

// An entry's required `name`: an identifier, and where it was written (for
// the duplicate checks across entries).
void Loader::read_name(TableReader& r, const toml::node* name_node, std::string& name, SourceLocation& spot,
               bool& has_spot) {
  if (auto v = r.string("name")) {
    if (is_identifier(*v)) {
      name = *v;
      spot = location(sink_, *name_node);
      has_spot = true;
    } else {
      r.error(*name_node, "name " + in_quotes(*v) + " is not allowed (allowed: 1 to 64 of A-Z a-z 0-9 _ - .)");
    }
  } else if (name_node == nullptr) {
    r.missing("name");
  }
}

}  // namespace cobridge::config::detail
