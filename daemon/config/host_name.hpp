// Host names in the one canonical form the web service compares them in:
// the names web.hosts lists and the host of a request's Host header field
// (RFC 9110 §7.2) go through the same function, so "GW1.Plant.Local.",
// "gw1.plant.local", "[::1]" and "::1" each compare equal to their twin.
// Thread: any; pure functions.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace cobridge::config {

// The canonical form of a DNS name or an IP address literal: a name
// lower-cased, without a final dot (labels of letters, digits, '-' and '_',
// 1..63 bytes each, 253 at most); an IPv4 address in dotted decimal; an
// IPv6 address as inet_ntop writes it, without brackets ("[::1]" and "::1"
// both give "::1"). nullopt for anything else: a port, a scheme, a path, a
// user, a space, an empty name.
[[nodiscard]] std::optional<std::string> canonical_host(std::string_view text);

// A canonical IP address literal of the loopback: 127.0.0.0/8, ::1,
// ::ffff:127.0.0.0/104.
[[nodiscard]] bool is_loopback_address(std::string_view canonical);

// A canonical IP address literal of every interface: 0.0.0.0 or ::.
[[nodiscard]] bool is_wildcard_address(std::string_view canonical);

}  // namespace cobridge::config
