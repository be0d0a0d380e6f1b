#include "base/error.hpp"

#include "base/json_writer.hpp"

#include <array>
#include <cstdio>

namespace cobridge {

std::string_view name(Errc kind) noexcept {
  static constexpr std::array<std::string_view, 9> kNames{
      "ok", "failed", "invalid_argument", "timeout", "permission_denied",
      "unavailable", "not_found", "unsupported", "internal"};
  const auto i = static_cast<std::size_t>(kind);
  return i < kNames.size() ? kNames[i] : std::string_view{"internal"};
}

std::string Error::to_string() const {
  if (where.empty()) return message;
  return where + ": " + message;
}

std::string json_quote(std::string_view text) {
  std::string out;
  out.reserve(text.size() + 2);
  out += '"';
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (c < 0x20 || c == 0x7F) {
          std::array<char, 8> buf{};
          std::snprintf(buf.data(), buf.size(), "\\u%04x", c);
          out += buf.data();
        } else {
          out += ch;
        }
    }
  }
  out += '"';
  return out;
}

std::string Error::to_json() const {
  JsonWriter w;
  w.begin_object().field("code", name(kind)).field("where", where).field("message", message);
  if (code) {
    w.key("detail").begin_object();
    w.field("category", code.category().name()).field("value", code.value());
    w.end_object();
  }
  return w.end_object().take();
}

}  // namespace cobridge
