// IpAllowList: the IP networks (CIDR) a listener accepts a client, or a
// client's writes, from. An empty list allows everyone. IPv4 clients that
// reach an IPv6 socket as v4-mapped addresses (::ffff:a.b.c.d) are matched
// against the IPv4 entries. Part of the plugin SDK so that the daemon's
// listeners (CiA 309-3 gateway) and the plugins' (Modbus TCP) match
// addresses with one implementation; header-only.
//
// Thread contract: built while a configuration is parsed, then only read
// (contains) by the thread that accepts clients.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <array>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

namespace cobridge {

class IpAllowList {
 public:
  // Adds "a.b.c.d[/n]" or "ipv6[/n]"; returns false if the text is not a network.
  [[nodiscard]] bool add(std::string_view cidr);
  [[nodiscard]] bool empty() const noexcept { return nets_.empty(); }
  // True if the address (AF_INET or AF_INET6 sockaddr) is allowed.
  [[nodiscard]] bool contains(const sockaddr* addr) const noexcept;
  // IPv4 address in host byte order.
  [[nodiscard]] bool contains_v4(std::uint32_t addr) const noexcept;
  // A write_allow list's verdict on a client: as contains(), except that a
  // client on the loopback address (127.0.0.0/8, ::1, v4-mapped 127.x) is
  // allowed only when the list is not empty and holds it. Any account of the
  // gateway's own host can connect to the loopback address, so an empty list
  // ("every client") would let it write around the Unix sockets'
  // write_group; taking local writers is an explicit choice.
  [[nodiscard]] bool allows_writer(const sockaddr* addr) const noexcept;
  [[nodiscard]] bool allows_writer_v4(std::uint32_t addr) const noexcept;
  // Is the address a loopback one (see allows_writer)?
  [[nodiscard]] static bool is_loopback(const sockaddr* addr) noexcept;

 private:
  struct Net {
    bool v6 = false;
    std::array<std::uint8_t, 16> addr{};
    unsigned prefix = 0;
  };
  [[nodiscard]] static bool match(const Net& n, const std::uint8_t* addr) noexcept;
  std::vector<Net> nets_;
};

inline bool IpAllowList::add(std::string_view cidr) {
  Net net;
  std::string_view host = cidr;
  std::string_view len;
  if (const auto slash = cidr.find('/'); slash != std::string_view::npos) {
    host = cidr.substr(0, slash);
    len = cidr.substr(slash + 1);
  }
  const std::string host_z(host);
  unsigned max_prefix = 32;
  if (inet_pton(AF_INET, host_z.c_str(), net.addr.data()) == 1) {
    net.v6 = false;
  } else if (inet_pton(AF_INET6, host_z.c_str(), net.addr.data()) == 1) {
    net.v6 = true;
    max_prefix = 128;
  } else {
    return false;
  }
  net.prefix = max_prefix;
  if (cidr.find('/') != std::string_view::npos) {
    unsigned p = 0;
    const auto [ptr, ec] = std::from_chars(len.data(), len.data() + len.size(), p);
    if (ec != std::errc{} || ptr != len.data() + len.size() || len.empty() || p > max_prefix) return false;
    net.prefix = p;
  }
  nets_.push_back(net);
  return true;
}

inline bool IpAllowList::match(const Net& n, const std::uint8_t* addr) noexcept {
  const unsigned full = n.prefix / 8;
  if (std::memcmp(n.addr.data(), addr, full) != 0) return false;
  const unsigned rest = n.prefix % 8;
  if (rest == 0) return true;
  const auto mask = static_cast<std::uint8_t>(0xFFu << (8 - rest));
  return (n.addr[full] & mask) == (addr[full] & mask);
}

inline bool IpAllowList::contains_v4(std::uint32_t addr) const noexcept {
  if (nets_.empty()) return true;
  const std::uint8_t bytes[4] = {static_cast<std::uint8_t>(addr >> 24), static_cast<std::uint8_t>(addr >> 16),
                                 static_cast<std::uint8_t>(addr >> 8), static_cast<std::uint8_t>(addr)};
  for (const Net& n : nets_) {
    if (!n.v6 && match(n, bytes)) return true;
  }
  return false;
}

inline bool IpAllowList::contains(const sockaddr* addr) const noexcept {
  if (nets_.empty()) return true;
  if (addr == nullptr) return false;
  if (addr->sa_family == AF_INET) {
    sockaddr_in in{};
    std::memcpy(&in, addr, sizeof in);
    return contains_v4(ntohl(in.sin_addr.s_addr));
  }
  if (addr->sa_family == AF_INET6) {
    sockaddr_in6 in6{};
    std::memcpy(&in6, addr, sizeof in6);
    const std::uint8_t* b = in6.sin6_addr.s6_addr;
    static constexpr std::uint8_t kMapped[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xFF, 0xFF};
    if (std::memcmp(b, kMapped, sizeof kMapped) == 0) {
      const std::uint32_t v4 = (static_cast<std::uint32_t>(b[12]) << 24) | (static_cast<std::uint32_t>(b[13]) << 16) |
                               (static_cast<std::uint32_t>(b[14]) << 8) | b[15];
      return contains_v4(v4);
    }
    for (const Net& n : nets_) {
      if (n.v6 && match(n, b)) return true;
    }
  }
  return false;
}

inline bool IpAllowList::allows_writer_v4(std::uint32_t addr) const noexcept {
  if ((addr >> 24) == 127 && nets_.empty()) return false;
  return contains_v4(addr);
}

inline bool IpAllowList::is_loopback(const sockaddr* addr) noexcept {
  if (addr == nullptr) return false;
  if (addr->sa_family == AF_INET) {
    sockaddr_in in{};
    std::memcpy(&in, addr, sizeof in);
    return (ntohl(in.sin_addr.s_addr) >> 24) == 127;
  }
  if (addr->sa_family != AF_INET6) return false;
  sockaddr_in6 in6{};
  std::memcpy(&in6, addr, sizeof in6);
  const std::uint8_t* b = in6.sin6_addr.s6_addr;
  static constexpr std::uint8_t kMapped[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xFF, 0xFF};
  if (std::memcmp(b, kMapped, sizeof kMapped) == 0) return b[12] == 127;
  static constexpr std::uint8_t kLoop6[16] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1};
  return std::memcmp(b, kLoop6, sizeof kLoop6) == 0;
}

inline bool IpAllowList::allows_writer(const sockaddr* addr) const noexcept {
  if (nets_.empty() && is_loopback(addr)) return false;
  return contains(addr);
}

}  // namespace cobridge
