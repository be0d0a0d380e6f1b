#include "app/number_text.hpp"

#include <charconv>
#include <cmath>
#include <system_error>

namespace cobridge::sim {

namespace {

bool has_hex_prefix(std::string_view t) noexcept {
  return t.size() > 2 && t[0] == '0' && (t[1] == 'x' || t[1] == 'X');
}

std::optional<std::uint64_t> whole(std::string_view t, int base) noexcept {
  if (t.empty()) return std::nullopt;
  std::uint64_t v = 0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v, base);
  if (ec != std::errc{} || end != t.data() + t.size()) return std::nullopt;
  return v;
}

}  // namespace

std::optional<std::uint64_t> parse_unsigned(std::string_view text, std::uint64_t max) noexcept {
  const auto v = has_hex_prefix(text) ? whole(text.substr(2), 16) : whole(text, 10);
  if (!v || *v > max) return std::nullopt;
  return v;
}

std::optional<std::uint32_t> parse_hex32(std::string_view text) noexcept {
  const auto v = whole(has_hex_prefix(text) ? text.substr(2) : text, 16);
  if (!v || *v > UINT32_MAX) return std::nullopt;
  return static_cast<std::uint32_t>(*v);
}

std::optional<double> parse_real(std::string_view text) noexcept {
  if (text.empty()) return std::nullopt;
  double v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v, std::chars_format::fixed);
  if (ec != std::errc{} || end != text.data() + text.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

}  // namespace cobridge::sim
