#include "web/peer_address.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <array>
#include <cstring>

namespace cobridge::web {
namespace {

std::string ntop(int family, const void* bytes) {
  std::array<char, INET6_ADDRSTRLEN> buf{};
  return ::inet_ntop(family, bytes, buf.data(), buf.size()) != nullptr ? std::string(buf.data()) : std::string();
}

// The IPv4 address inside an IPv4-mapped IPv6 one.
in_addr mapped_v4(const in6_addr& a) {
  in_addr v4{};
  std::memcpy(&v4, &a.s6_addr[12], sizeof v4);
  return v4;
}

}  // namespace

std::string address_text(const sockaddr* address) {
  if (address == nullptr) return {};
  if (address->sa_family == AF_INET) return ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(address)->sin_addr);
  if (address->sa_family != AF_INET6) return {};
  const in6_addr& a = reinterpret_cast<const sockaddr_in6*>(address)->sin6_addr;
  if (IN6_IS_ADDR_V4MAPPED(&a)) {
    const in_addr v4 = mapped_v4(a);
    return ntop(AF_INET, &v4);
  }
  return ntop(AF_INET6, &a);
}

std::string throttle_key(const sockaddr* address) {
  if (address == nullptr || address->sa_family != AF_INET6) return address_text(address);
  in6_addr a = reinterpret_cast<const sockaddr_in6*>(address)->sin6_addr;
  if (IN6_IS_ADDR_V4MAPPED(&a)) return address_text(address);
  std::memset(&a.s6_addr[8], 0, 8);  // keep the /64
  return ntop(AF_INET6, &a) + "/64";
}

std::string local_address(int fd) {
  sockaddr_storage ss{};
  socklen_t len = sizeof ss;
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&ss), &len) != 0) return {};
  return address_text(reinterpret_cast<const sockaddr*>(&ss));
}

}  // namespace cobridge::web
