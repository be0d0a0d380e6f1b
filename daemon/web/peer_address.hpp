// The two ends of a web connection as text: the client's address (for the
// log and the login throttle) and the address the connection arrived at
// (for the Host check), in the canonical form of config/host_name.hpp.
// Thread: any; pure functions (local_address() asks the kernel).
#pragma once

#include <string>

struct sockaddr;

namespace cobridge::web {

// "192.0.2.7", "2001:db8::5"; an IPv4-mapped IPv6 address as its IPv4
// ("::ffff:192.0.2.7" -> "192.0.2.7"); "" for nullptr or another family.
[[nodiscard]] std::string address_text(const sockaddr* address);

// The client as LoginThrottle counts it: an IPv4 address, or an IPv6 /64
// ("2001:db8:1:2::/64"): an IPv6 host picks its address from a /64, so
// counting single addresses would give it 2^64 fresh starts.
[[nodiscard]] std::string throttle_key(const sockaddr* address);

// The address the connection on socket `fd` arrived at (getsockname), as
// address_text(); "" when the kernel does not say.
[[nodiscard]] std::string local_address(int fd);

}  // namespace cobridge::web
