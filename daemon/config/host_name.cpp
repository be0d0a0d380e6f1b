#include "config/host_name.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>

#include <array>
#include <cstring>

namespace cobridge::config {
namespace {

constexpr std::size_t kMaxName = 253;
constexpr std::size_t kMaxLabel = 63;

bool is_name_byte(char c) noexcept {
  return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '_';
}

char lower(char c) noexcept { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; }

// `text` as inet_ntop writes the address, or nullopt when it is not one.
std::optional<std::string> canonical_ip(const std::string& text) {
  in_addr a4{};
  in6_addr a6{};
  std::array<char, INET6_ADDRSTRLEN> buf{};
  if (::inet_pton(AF_INET, text.c_str(), &a4) == 1 && ::inet_ntop(AF_INET, &a4, buf.data(), buf.size()) != nullptr)
    return std::string(buf.data());
  if (::inet_pton(AF_INET6, text.c_str(), &a6) == 1 && ::inet_ntop(AF_INET6, &a6, buf.data(), buf.size()) != nullptr)
    return std::string(buf.data());
  return std::nullopt;
}

std::optional<std::string> canonical_name(std::string_view text) {
  if (!text.empty() && text.back() == '.') text.remove_suffix(1);  // "gw1.plant.local." is the same name
  if (text.empty() || text.size() > kMaxName) return std::nullopt;
  std::string name;
  std::size_t label = 0;
  bool digits_only = true;  // of the last label
  for (const char c : text) {
    if (c == '.') {
      if (label == 0) return std::nullopt;
      label = 0;
      digits_only = true;
    } else if (!is_name_byte(lower(c)) || ++label > kMaxLabel) {
      return std::nullopt;
    } else {
      digits_only = digits_only && c >= '0' && c <= '9';
    }
    name += lower(c);
  }
  // A last label of digits ("10.1.2", "127.1") is an IPv4 address to a
  // browser (WHATWG URL), never the name it would send: refused, not kept
  // as a name nothing matches.
  if (label == 0 || digits_only) return std::nullopt;
  return name;
}

}  // namespace

std::optional<std::string> canonical_host(std::string_view text) {
  if (text.size() >= 2 && text.front() == '[' && text.back() == ']') {
    const std::string inside(text.substr(1, text.size() - 2));
    if (inside.find(':') == std::string::npos) return std::nullopt;  // brackets are for IPv6 only
    return canonical_ip(inside);
  }
  if (text.find(':') != std::string::npos) return canonical_ip(std::string(text));  // IPv6 without brackets
  if (auto ip = canonical_ip(std::string(text))) return ip;
  return canonical_name(text);
}

bool is_loopback_address(std::string_view canonical) {
  const std::string text(canonical);
  in_addr a4{};
  in6_addr a6{};
  if (::inet_pton(AF_INET, text.c_str(), &a4) == 1) return (ntohl(a4.s_addr) >> 24) == 127;
  if (::inet_pton(AF_INET6, text.c_str(), &a6) != 1) return false;
  if (IN6_IS_ADDR_LOOPBACK(&a6)) return true;
  return IN6_IS_ADDR_V4MAPPED(&a6) && a6.s6_addr[12] == 127;
}

bool is_wildcard_address(std::string_view canonical) { return canonical == "0.0.0.0" || canonical == "::"; }

}  // namespace cobridge::config
