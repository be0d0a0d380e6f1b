// DcmdRequest: one Sparkplug DCMD (spec 6.4.x "DCMD": a host application
// writes metrics its device's DBIRTH declared) decoded into the one
// command it asks for: preset, NMT reset or store, and the sender's
// Command/Client string. MQTT 3.1.1 tells a subscriber nothing about who
// published a message, so the sender names itself in Command/Client; it is
// required, logged and echoed with the outcome, but it is a claim, not an
// identity: who may publish to the DCMD topic at all is the broker's ACL.
//
// A payload that is not a Sparkplug payload, names a metric that is not a
// writable command metric, gives a metric the wrong datatype, asks for no
// command or for more than one, or lacks Command/Client is malformed: kind
// stays 0 and `error` says what and where (the metric's name or alias).
//
// Thread contract: parse_dcmd() runs on libmosquitto's client thread (it
// allocates through protobuf-c's unpack; a DCMD is rare); the request is
// trivially copyable and crosses to the publisher thread in an SpscRing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <type_traits>

namespace cobridge::mqtt {

struct DcmdRequest {
  char device_id[64] = {};  // from the topic: spBv1.0/<group>/DCMD/<edge>/<device_id>
  char client[64] = {};     // Command/Client
  std::uint8_t kind = 0;    // enum cobridge_command_kind; 0 = malformed (see error)
  std::int64_t value = 0;   // PRESET: the position in counts
  // The device index the metric's alias names ((alias >> 8) - 1), -1 when
  // the metrics came by name: an alias of another device is malformed.
  std::int32_t alias_device = -1;
  char error[160] = {};
};
static_assert(std::is_trivially_copyable_v<DcmdRequest>, "copied through an SpscRing");

// Decodes `data` (a DCMD payload for `device_id`). Never throws.
[[nodiscard]] DcmdRequest parse_dcmd(std::string_view device_id, const std::uint8_t* data, std::size_t len) noexcept;

// "preset", "nmt_reset", "store" (the names the write_allow key takes); "?" otherwise.
[[nodiscard]] const char* command_name(std::uint8_t kind) noexcept;

}  // namespace cobridge::mqtt
