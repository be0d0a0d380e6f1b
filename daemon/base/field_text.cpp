#include "base/field_text.hpp"

namespace cobridge {

namespace {

bool needs_escape(char c) noexcept {
  return c == ' ' || c == '\t' || c == '%' || c == '=' || c == '#' || static_cast<unsigned char>(c) < 0x20 ||
         static_cast<unsigned char>(c) == 0x7F;
}

int hex_digit(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

Error bad_escape(std::string_view text) {
  return Error(Errc::kInvalidArgument, "bad %-escape in '" + log_excerpt(text, 60) + "'");
}

// The next blank-separated token from `pos` on; empty at the end.
std::string_view next_token(std::string_view line, std::size_t& pos) noexcept {
  while (pos < line.size() && (line[pos] == ' ' || line[pos] == '\t')) ++pos;
  std::size_t end = pos;
  while (end < line.size() && line[end] != ' ' && line[end] != '\t') ++end;
  const std::string_view token = line.substr(pos, end - pos);
  pos = end;
  return token;
}

}  // namespace

std::string escape_field(std::string_view text) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    if (needs_escape(c)) {
      const auto u = static_cast<unsigned char>(c);
      out += '%';
      out += kHex[u >> 4];
      out += kHex[u & 0x0F];
    } else {
      out += c;
    }
  }
  return out;
}

Result<std::string> unescape_field(std::string_view text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '%') {
      out += text[i];
      continue;
    }
    if (i + 2 >= text.size()) return bad_escape(text);
    const int hi = hex_digit(text[i + 1]);
    const int lo = hex_digit(text[i + 2]);
    if (hi < 0 || lo < 0) return bad_escape(text);
    out += static_cast<char>((hi << 4) | lo);
    i += 2;
  }
  return out;
}

Result<Fields> split_fields(std::string_view line) {
  Fields out;
  std::size_t pos = 0;
  for (std::string_view token = next_token(line, pos); !token.empty(); token = next_token(line, pos)) {
    const auto eq = token.find('=');
    if (eq == std::string_view::npos || eq == 0) {
      return Error(Errc::kInvalidArgument, "expected key=value, got '" + std::string(token) + "'");
    }
    Result<std::string> value = unescape_field(token.substr(eq + 1));
    if (!value.ok()) return Error(Errc::kInvalidArgument, "bad %-escape in '" + std::string(token) + "'");
    out.emplace_back(std::string(token.substr(0, eq)), std::move(*value));
  }
  return out;
}

std::string log_excerpt(std::string_view text, std::size_t max) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  for (const char c : text) {
    const auto u = static_cast<unsigned char>(c);
    const bool plain = u >= 0x20 && u < 0x7F;
    if (out.size() + (plain ? 1 : 4) > max) return out + "...";
    if (plain) {
      out += c;
    } else {
      out += "\\x";
      out += kHex[u >> 4];
      out += kHex[u & 0x0F];
    }
  }
  return out;
}

}  // namespace cobridge
