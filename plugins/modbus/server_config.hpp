// ServerConfig: the Modbus output's configuration, parsed from the TOML text
// of its [outputs.<name>] table. Unknown keys are errors that name the key,
// so a typo never silently falls back to a default.
//
//   bind              = "127.0.0.1" IPv4 or IPv6 address to listen on ("0.0.0.0": every interface)
//   port              = 1502        TCP port (502 needs CAP_NET_BIND_SERVICE); 0 = any free port
//   max_clients       = 32          connections served at once; more are closed at accept
//   allow             = []          CIDR networks allowed to connect; empty = all
//   write_allow       = []          CIDR networks whose writes are taken (writes_enabled); empty = all
//   idle_timeout_s    = 60          close a connection silent for this long; 0 = never
//   first_request_timeout_ms = 2000 close a connection that sent no request this long
//                                   after connecting; 0 = only idle_timeout_s applies
//   unit_id           = (absent)    answer only this unit id (0..255); absent = any
//   word_order        = "big"       32-bit values: "big" = high word first, "little"
//   writes_enabled    = false       see docs/modbus.md: refused in this version either way
//   offline_exception = false       reads touching an offline device answer 0x0B
//   max_devices       = 32          device slots in the map (1..2016)
//
// Thread contract: parsed on the daemon's control thread (plugin create).
#pragma once

#include "register_image.hpp"
#include "request.hpp"

#include <cobridge/ip_allow_list.hpp>
#include <cobridge/plugin_error.hpp>

#include <cstdint>
#include <string>
#include <string_view>

namespace cobridge::modbus {

struct ServerConfig {
  std::string bind = "127.0.0.1";
  std::uint16_t port = 1502;
  std::uint32_t max_clients = 32;
  IpAllowList allow;
  IpAllowList write_allow;  // empty: writes (when enabled) from every allowed client
  std::uint32_t idle_timeout_s = 60;
  std::uint32_t first_request_timeout_ms = 2000;
  int unit_id = -1;
  WordOrder word_order = WordOrder::kBig;
  bool writes_enabled = false;
  bool offline_exception = false;
  std::uint16_t max_devices = 32;

  [[nodiscard]] RequestPolicy policy() const noexcept { return {unit_id, writes_enabled, offline_exception}; }
};

// The precise codes of a configuration error, the SDK's set for every plugin.
using ConfigErrc = plugin::ConfigErrc;

// Fills `out` only on success; the error's message starts "config: ", ready for
// the plugin's err text.
[[nodiscard]] plugin::Error parse_config(std::string_view toml_text, ServerConfig& out);

}  // namespace cobridge::modbus
