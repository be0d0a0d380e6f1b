// Exposure: what a configuration opens to the network, said where it is
// written. The daemon runs as configured; these are
// warnings, printed by --check-config and logged at start and on reload, so
// that a plant's reviewer sees every door in one place:
//   - a listener on a non-loopback address without TLS or authentication
//     ([web] without tls_cert or auth_file; the CiA 309-3 TCP listener and an
//     output's `bind`, which have no authentication at all);
//   - writes reachable from the network without an allow list (309-3 and an
//     output with writes_enabled and no write_allow);
//   - writes taken from this host's loopback address (a write_allow that
//     lists it): every local account then writes around write_group;
//   - a TLS private key readable by group or others.
// Outputs are read by convention (`bind`, `writes_enabled`, `write_allow` in
// their table), without loading the plugin.
//
// Thread: the main thread (validation); reads the key file's mode.
#pragma once

#include "config/config.hpp"

#include <string>
#include <vector>

namespace cobridge::app {

// "file:line:column: what is exposed, and what to do", in file order of sections.
[[nodiscard]] std::vector<std::string> exposure_warnings(const config::Config& config);

// True for 127.0.0.0/8 and ::1 (IP literals only; a bind is one).
[[nodiscard]] bool is_loopback(const std::string& address);

}  // namespace cobridge::app
