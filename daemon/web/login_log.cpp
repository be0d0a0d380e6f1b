#include "web/login_log.hpp"

#include <array>

namespace cobridge::web {
namespace {

constexpr std::size_t kMaxUserBytes = 64;

std::string since_last_line(const LoginThrottle::Verdict& v) {
  if (v.failed_unlogged == 0 && v.refused_unlogged == 0) return {};
  return "; since the last line: " + std::to_string(v.failed_unlogged) + " more failed, " +
         std::to_string(v.refused_unlogged) + " refused";
}

std::string from(std::string_view client) {
  return "from " + (client.empty() ? std::string("an unknown address") : std::string(client));
}

std::string as_user(std::string_view user) {
  return user.empty() ? "without a user name" : "as \"" + printable_user(user) + "\"";
}

}  // namespace

std::string printable_user(std::string_view user) {
  static constexpr std::array<char, 16> kHex = {'0', '1', '2', '3', '4', '5', '6', '7',
                                                '8', '9', 'a', 'b', 'c', 'd', 'e', 'f'};
  std::string out;
  for (std::size_t i = 0; i < user.size() && i < kMaxUserBytes; ++i) {
    const auto c = static_cast<unsigned char>(user[i]);
    if (c >= 0x20 && c < 0x7F && c != '"' && c != '\\') {
      out += static_cast<char>(c);
    } else {
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  if (user.size() > kMaxUserBytes) out += "...";
  return out;
}

long long seconds_up(LoginThrottle::Clock::duration d) noexcept {
  const auto s = std::chrono::ceil<std::chrono::seconds>(d).count();
  return s < 1 ? 1 : static_cast<long long>(s);
}

std::string failed_login_line(std::string_view client, std::string_view user, const LoginThrottle::Verdict& v) {
  return "failed login " + from(client) + " " + as_user(user) + " (" + std::to_string(v.failures) +
         " in a row); credentials not checked for " + std::to_string(seconds_up(v.retry_after)) + " s" +
         since_last_line(v);
}

std::string refused_login_line(std::string_view client, std::string_view user, const LoginThrottle::Verdict& v) {
  return "login " + from(client) + " " + as_user(user) + " refused (429): " +
         std::to_string(v.failures) + " failed in a row, " + std::to_string(seconds_up(v.retry_after)) + " s left" +
         since_last_line(v);
}

}  // namespace cobridge::web
