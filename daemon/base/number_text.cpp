#include "base/number_text.hpp"

#include <array>
#include <charconv>
#include <cstdio>

namespace cobridge {

bool parse_unsigned(std::string_view text, std::uint64_t max, std::uint64_t& out, bool hex) noexcept {
  int base = hex ? 16 : 10;
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    text.remove_prefix(2);
    base = 16;
  }
  if (text.empty()) return false;
  std::uint64_t v = 0;
  const auto* end = text.data() + text.size();
  const auto r = std::from_chars(text.data(), end, v, base);
  if (r.ec != std::errc() || r.ptr != end || v > max) return false;
  out = v;
  return true;
}

bool parse_signed(std::string_view text, std::int64_t min, std::int64_t max, std::int64_t& out) noexcept {
  if (min > 0 || max < 0) return false;
  const bool negative = !text.empty() && text[0] == '-';
  if (negative) text.remove_prefix(1);
  // The magnitude's bound, in unsigned arithmetic: -min does not fit int64 for INT64_MIN.
  const std::uint64_t limit = negative ? 0 - static_cast<std::uint64_t>(min) : static_cast<std::uint64_t>(max);
  std::uint64_t magnitude = 0;
  if (!parse_unsigned(text, limit, magnitude)) return false;  // a second sign is refused there
  out = negative ? static_cast<std::int64_t>(0 - magnitude) : static_cast<std::int64_t>(magnitude);
  return true;
}

bool parse_hex_bytes(std::string_view text, std::size_t max_bytes, std::vector<std::uint8_t>& out) {
  if (text.empty() || text.size() % 2 != 0 || text.size() / 2 > max_bytes) return false;
  for (std::size_t i = 0; i < text.size(); i += 2) {
    std::uint8_t b = 0;
    const auto r = std::from_chars(text.data() + i, text.data() + i + 2, b, 16);
    if (r.ec != std::errc() || r.ptr != text.data() + i + 2) return false;
    out.push_back(b);
  }
  return true;
}

std::string hex(std::uint64_t v, int digits) {
  std::array<char, 24> buf{};
  std::snprintf(buf.data(), buf.size(), "0x%0*llX", digits, static_cast<unsigned long long>(v));
  return buf.data();
}

std::string hex_bytes(std::span<const std::uint8_t> data) {
  static constexpr char kDigits[] = "0123456789ABCDEF";
  std::string out;
  out.reserve(data.size() * 2);
  for (const std::uint8_t b : data) {
    out += kDigits[b >> 4];
    out += kDigits[b & 0xF];
  }
  return out;
}

std::string object_text(std::uint16_t index, std::uint8_t sub) {
  std::string s = hex(index, 4);
  if (sub != 0) s += "/" + std::to_string(sub);
  return s;
}

}  // namespace cobridge
