// Fuzz target: field text (daemon/base/field_text.*), the line format of the
// state file and the timeline journals. Feeds the bytes three ways: as a value
// to escape, as a value to unescape and as a whole line to split, and as text
// for log_excerpt. Invariants (abort on violation), as the header promises:
//   * "a line reads back exactly": unescape_field(escape_field(x)) == x, and
//     an escaped value holds no blank, '=', '#' or control byte;
//   * a line of key=escape(value) fields splits into exactly those fields;
//   * split_fields on any line either fails with a why or gives non-empty
//     keys without '=' or blanks;
//   * log_excerpt(x, max) is printable ASCII, at most max + 3 bytes ("..."),
//     and x itself when x is printable and fits ("a file's content never
//     reaches a log whole").
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "base/field_text.hpp"

using namespace cobridge;

namespace {

bool printable(char c) noexcept {
  const auto u = static_cast<unsigned char>(c);
  return u >= 0x20 && u < 0x7F;
}

void check_round_trip(std::string_view value) {
  const std::string escaped = escape_field(value);
  for (const char c : escaped) {
    const auto u = static_cast<unsigned char>(c);
    if (c == ' ' || c == '\t' || c == '=' || c == '#' || u < 0x20 || u == 0x7F) std::abort();
  }
  const Result<std::string> back = unescape_field(escaped);
  if (!back.ok() || *back != value) std::abort();
}

// The input cut at each ',' into values, written as k0=..., k1=... and split.
void check_line(std::string_view text) {
  Fields values;
  for (std::size_t pos = 0; pos <= text.size();) {
    const std::size_t end = std::min(text.find(',', pos), text.size());
    values.emplace_back("k" + std::to_string(values.size()), std::string(text.substr(pos, end - pos)));
    pos = end + 1;
  }
  std::string line;
  for (const auto& [key, value] : values) line += (line.empty() ? "" : " ") + key + "=" + escape_field(value);
  const Result<Fields> fields = split_fields(line);
  if (!fields.ok() || *fields != values) std::abort();
}

void check_arbitrary(std::string_view text) {
  (void)unescape_field(text);
  const Result<Fields> fields = split_fields(text);
  if (fields.ok()) {
    for (const auto& [key, value] : *fields)
      if (key.empty() || key.find_first_of("= \t") != std::string::npos) std::abort();
  } else if (fields.error().message.empty() || fields.error().kind != Errc::kInvalidArgument) {
    std::abort();
  }
}

void check_excerpt(std::string_view text, std::size_t max) {
  const std::string excerpt = log_excerpt(text, max);
  if (excerpt.size() > max + 3) std::abort();
  for (const char c : excerpt)
    if (!printable(c)) std::abort();
  bool plain = text.size() <= max;
  for (const char c : text) plain = plain && printable(c);
  if (plain && excerpt != text) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  check_round_trip(text);
  check_line(text);
  check_arbitrary(text);
  check_excerpt(text, size == 0 ? 0 : data[0] % 130);
  return 0;
}
