// Sample mapping: fills the IDL types of cobridge.idl (generated C structs)
// from a cobridge_sample and the plugin's DeviceSlot.
//
// The string members of the generated structs are `char*`; they are pointed
// at storage that outlives the dds_write call (the slot table, the gateway
// id, a caller-provided EmcyText on the stack), so filling a struct never
// allocates. dds_write only reads through those pointers.
//
// Thread contract: the dispatcher thread (hot path): noexcept, no allocation.
#pragma once

#include "dds/device_slots.hpp"

#include <cobridge/emcy.h>
#include <cobridge/plugin.h>

#include "cobridge_idl/cobridge.h"

#include <array>
#include <cstdint>
#include <string_view>

namespace cobridge::dds {

// The gateway as the topics name it: its id, and the id's FNV-1a 64 hash,
// the first key member of every topic. A fixed-size key lets Cyclone
// serialise the key without allocating (a string key costs two heap
// allocations per dds_write in Cyclone 0.10.2; docs/performance.md).
struct GatewayName {
  const char* id = "";
  std::uint64_t key = 0;
};
[[nodiscard]] std::uint64_t gateway_key(std::string_view gateway_id) noexcept;

// NUL-terminated copies of the EMCY meaning, for EncoderEvent's strings.
struct EmcyText {
  std::array<char, 160> text{};
  std::array<char, 24> source{};
  bool error_reset = false;
};

// The meaning of an EMCY per the device family's manual, through the SDK
// (cobridge_emcy_classify). `family` as announced: "novotechnik-rotary",
// "novotechnik-multiturn", "ifm-rm"; anything else gets the CiA 301 texts.
void describe_emcy(const char* family, const cobridge_sample& s, EmcyText& out) noexcept;

// The number a topic carries for sample `s`: its per-device-and-kind
// kind_sequence (COBRIDGE_VALID_KIND_SEQUENCE), so that a gap on the topic
// is exactly a lost sample of that topic; from a daemon that does not set it,
// the per-device sequence of all kinds (its meaning in plugin ABI 1).
[[nodiscard]] std::uint32_t topic_sequence(const cobridge_sample& s) noexcept;

// EncoderSample from a TPDO sample. `slot` may be nullptr (device beyond the
// table): the name is then "". `stale` overrides the sample's own flag (for
// the re-publication of the last values when a device turns stale).
void fill_encoder_sample(cobridge_EncoderSample& out, const cobridge_sample& s, const GatewayName& gateway,
                         const DeviceSlot* slot, bool stale) noexcept;

// EncoderEvent from an EMCY sample; the strings point into `text`.
void fill_encoder_event(cobridge_EncoderEvent& out, const cobridge_sample& s, const GatewayName& gateway,
                        const DeviceSlot* slot, const EmcyText& text) noexcept;

// DeviceStatus from a slot.
void fill_device_status(cobridge_DeviceStatus& out, const DeviceSlot& slot, const GatewayName& gateway) noexcept;

}  // namespace cobridge::dds
