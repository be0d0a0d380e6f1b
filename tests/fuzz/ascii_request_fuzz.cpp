// Fuzz target: the CiA 309-3 ASCII gateway's request parser
// (daemon/control/ascii/ascii_request.*). Any line gives a request or one
// of the standard's error numbers; a read answer is formatted for every type.
//
// Accepted implies representable. Whenever the parser accepts a
// write of an integer type, the bytes it will write, read back as that
// type, are the number the value's text denotes, and that number is in the
// type's range (nothing cut to the type's width). The number is worked out
// here, apart from the parser: [-](decimal | 0x hex), the '-' for signed
// types only. The input is tried twice: as a whole line, and (first byte:
// the type, the rest: the value) as the value of an otherwise valid write,
// where a well-formed number in range must also be accepted.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "control/ascii/ascii_request.hpp"

namespace {

using cobridge::control::AsciiError;
using cobridge::control::AsciiRequest;
using cobridge::control::AsciiType;
using cobridge::control::parse_ascii_request;

struct IntegerType {
  const char* name;
  AsciiType type;
  unsigned bits;
  bool is_signed;
};
constexpr IntegerType kIntegerTypes[] = {
    {"b", AsciiType::b, 8, false},      {"i8", AsciiType::i8, 8, true},     {"i16", AsciiType::i16, 16, true},
    {"i32", AsciiType::i32, 32, true},  {"i64", AsciiType::i64, 64, true},  {"u8", AsciiType::u8, 8, false},
    {"u16", AsciiType::u16, 16, false}, {"u32", AsciiType::u32, 32, false}, {"u64", AsciiType::u64, 64, false},
    {"x8", AsciiType::x8, 8, false},    {"x16", AsciiType::x16, 16, false}, {"x32", AsciiType::x32, 32, false},
    {"x64", AsciiType::x64, 64, false},
};
constexpr std::size_t kIntegerTypeCount = sizeof kIntegerTypes / sizeof kIntegerTypes[0];

const IntegerType* integer_type(AsciiType t) {
  for (const auto& i : kIntegerTypes) {
    if (i.type == t) return &i;
  }
  return nullptr;
}

// The number a value's text denotes: sign and magnitude; `ok` false when
// the text is no number of the grammar (decimal without a leading 0 before
// digits, or 0x-hex) or its magnitude passes 2^64 - 1.
struct Denoted {
  bool ok = false;
  bool negative = false;
  std::uint64_t magnitude = 0;
};

int digit_value(char c, unsigned base) {
  int d = -1;
  if (c >= '0' && c <= '9') d = c - '0';
  else if (c >= 'a' && c <= 'f') d = c - 'a' + 10;
  else if (c >= 'A' && c <= 'F') d = c - 'A' + 10;
  return d >= 0 && static_cast<unsigned>(d) < base ? d : -1;
}

Denoted denoted(std::string_view t, bool sign_allowed) {
  Denoted n;
  if (sign_allowed && !t.empty() && t[0] == '-') {
    n.negative = true;
    t.remove_prefix(1);
  }
  // "010": octal to CANopenNode, so no number of our grammar (refused).
  if (t.size() > 1 && t[0] == '0' && t[1] >= '0' && t[1] <= '9') return n;
  unsigned base = 10;
  if (t.size() > 2 && t[0] == '0' && (t[1] == 'x' || t[1] == 'X')) {
    base = 16;
    t.remove_prefix(2);
  }
  if (t.empty()) return n;
  for (const char c : t) {
    const int d = digit_value(c, base);
    if (d < 0 || n.magnitude > (UINT64_MAX - static_cast<std::uint64_t>(d)) / base) return n;
    n.magnitude = n.magnitude * base + static_cast<std::uint64_t>(d);
  }
  n.ok = true;
  return n;
}

bool in_range(const Denoted& n, const IntegerType& t) {
  if (t.type == AsciiType::b) return !n.negative && n.magnitude <= 1;
  if (!t.is_signed) return !n.negative && (t.bits == 64 || n.magnitude < (std::uint64_t{1} << t.bits));
  const std::uint64_t half = std::uint64_t{1} << (t.bits - 1);  // |min|; max is half - 1
  return n.negative ? n.magnitude <= half : n.magnitude < half;
}

// The written bytes, read back as the type, are the number (given in range,
// its bit pattern of the type's width names it).
bool reads_back_as(const AsciiRequest& r, const Denoted& n, const IntegerType& t) {
  if (r.command.data.size() != t.bits / 8) return false;
  std::uint64_t got = 0;
  for (std::size_t i = 0; i < r.command.data.size(); ++i) got |= std::uint64_t{r.command.data[i]} << (8 * i);
  std::uint64_t want = n.negative ? 0 - n.magnitude : n.magnitude;
  if (t.bits < 64) want &= (std::uint64_t{1} << t.bits) - 1;
  return got == want;
}

// An accepted integer write of `value` as `t`: the number in range, written whole.
void check_accepted(const AsciiRequest& r, const IntegerType& t, std::string_view value) {
  const Denoted n = denoted(value, t.is_signed);
  if (!n.ok || !in_range(n, t) || !reads_back_as(r, n, t)) std::abort();
}

// The last blank-separated word of a line without quotes (for a write, its value).
std::string_view last_word(std::string_view line) {
  const auto end = line.find_last_not_of(" \t\r");
  if (end == std::string_view::npos) return {};
  const auto blank = line.find_last_of(" \t\r", end);
  const std::size_t begin = blank == std::string_view::npos ? 0 : blank + 1;
  return line.substr(begin, end + 1 - begin);
}

void whole_line(std::string_view line) {
  const auto r = parse_ascii_request(line);
  if ((r.kind == AsciiRequest::Kind::invalid) == (r.error == AsciiError::none)) std::abort();
  const IntegerType* t = integer_type(r.type);
  // A quoted word may hold blanks: only lines without quotes are split here.
  if (r.kind != AsciiRequest::Kind::write || t == nullptr || line.find('"') != std::string_view::npos) return;
  check_accepted(r, *t, last_word(line));
}

void value_of_a_write(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return;
  const IntegerType& t = kIntegerTypes[data[0] % kIntegerTypeCount];
  const std::string_view value(reinterpret_cast<const char*>(data + 1), size - 1);
  if (value.find_first_of(std::string_view(" \t\r\"", 4)) != std::string_view::npos) return;  // not one plain word
  const auto r = parse_ascii_request(std::string("[1] 10 w 0x2000 0 ") + t.name + " " + std::string(value));
  const Denoted n = denoted(value, t.is_signed);
  const bool representable = n.ok && in_range(n, t);
  if (representable != (r.kind == AsciiRequest::Kind::write)) std::abort();
  if (representable) check_accepted(r, t, value);
  else if (r.error != AsciiError::syntax) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace cobridge::control;
  whole_line(std::string_view(reinterpret_cast<const char*>(data), size));
  value_of_a_write(data, size);
  for (int t = 0; t <= static_cast<int>(AsciiType::os); ++t)
    (void)ascii_format(static_cast<AsciiType>(t), std::span<const std::uint8_t>(data, size < 16 ? size : 16));
  return 0;
}
