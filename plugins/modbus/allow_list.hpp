// AllowList: the IP networks (CIDR) whose clients the Modbus server accepts.
// An empty list accepts everyone. IPv4 clients that reach an IPv6 socket as
// v4-mapped addresses (::ffff:a.b.c.d) are matched against the IPv4 entries.
//
// Thread contract: built on the control thread (config parsing), then only
// read (contains) by the server thread.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

struct sockaddr;

namespace cobridge::modbus {

class AllowList {
 public:
  // Adds "a.b.c.d[/n]" or "ipv6[/n]"; returns false if the text is not a network.
  [[nodiscard]] bool add(std::string_view cidr);
  [[nodiscard]] bool empty() const noexcept { return nets_.empty(); }
  // True if the address (AF_INET or AF_INET6 sockaddr) is allowed.
  [[nodiscard]] bool contains(const sockaddr* addr) const noexcept;
  // IPv4 address in host byte order.
  [[nodiscard]] bool contains_v4(std::uint32_t addr) const noexcept;

 private:
  struct Net {
    bool v6 = false;
    std::array<std::uint8_t, 16> addr{};
    unsigned prefix = 0;
  };
  [[nodiscard]] static bool match(const Net& n, const std::uint8_t* addr) noexcept;
  std::vector<Net> nets_;
};

}  // namespace cobridge::modbus
