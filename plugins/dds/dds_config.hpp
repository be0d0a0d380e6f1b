// DdsConfig: the DDS plugin's configuration, parsed from the TOML text of its
// instance table (see docs/dds.md). Unknown keys are refused by name so that
// a typo does not silently fall back to a default.
//
// Thread contract: parse_dds_config runs in cobridge_plugin_create on the
// daemon's control thread; it allocates, reads the DDS Security files
// (dds_security.hpp) and may be slow.
#pragma once

#include "dds/dds_security.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>

namespace cobridge::dds {

enum class Reliability : std::uint8_t { kBestEffort, kReliable };

// Which thread writes EncoderSample (docs/dds.md, "Threads and cost").
enum class SamplePath : std::uint8_t {
  kAuto,          // the dispatcher; a write that finds the reliable history full, and those
                  // after it, go to the writer thread, which waits for room (spill)
  kDispatcher,    // the dispatcher only: a full reliable history fails the write at once
  kWriterThread,  // queued to the plugin's writer thread, like the other topics
};

struct DdsConfig {
  // DDS domain id; the default port mapping allows 0..232.
  std::uint32_t domain = 0;
  // QoS of the EncoderSample writer; events and status are always reliable.
  Reliability sample_reliability = Reliability::kBestEffort;
  // Keep-last depth of the EncoderSample writer, per instance (device).
  std::int32_t sample_depth = 1;
  // Prepended to the topic names ("plant1/" -> "plant1/EncoderSample").
  std::string topic_prefix;
  // DDS partition of every writer (and of the GatewayStatus reader); "" =
  // the default partition. Subscribers must name the same partition.
  std::string partition;
  // Cyclone's Internal/WriteBatch: the writer thread packs everything it
  // drained at once into one RTPS message (one sendto) instead of one per
  // sample, and flushes after each drained batch. Lower median latency and
  // a higher sustainable rate (docs/performance.md, "DDS latency").
  bool write_batch = true;
  // Liveliness lease of every writer (AUTOMATIC): a subscriber sees the
  // instances of a gateway that died turn NOT_ALIVE_NO_WRITERS after at
  // most this long (docs/dds.md, "Many gateways in one domain").
  std::int64_t liveliness_lease_ms = 500;
  // Who writes EncoderSample. "auto" by default: the dispatcher's direct
  // write is what keeps the p99 at bare Cyclone's (docs/performance-notes.md,
  // "DDS latency"), the spill keeps the writer thread's patience with a slow
  // reliable reader.
  SamplePath sample_path = SamplePath::kAuto;
  // [outputs.dds.security]: DDS Security with these files (checked at load,
  // dds_security.hpp); none = off, anyone on the network may read and write.
  std::optional<DdsSecurity> security;
  // Not a TOML key: the host's [redundancy] node_id (ABI 4), 0 = alone. In a
  // pair the data writers have EXCLUSIVE ownership (pair_role.hpp).
  std::uint8_t redundancy_node = 0;

  // True when on_samples writes EncoderSample on the dispatcher thread (the
  // sample writer then has max_blocking_time 0).
  [[nodiscard]] bool samples_on_dispatcher() const noexcept { return sample_path != SamplePath::kWriterThread; }
  // True when a write that finds the history full goes to the writer thread.
  [[nodiscard]] bool spill_to_writer_thread() const noexcept { return sample_path == SamplePath::kAuto; }
};

// The precise codes of a configuration error, the SDK's set for every plugin.
using DdsConfigErrc = plugin::ConfigErrc;

// The configuration, or (error set) why the table is refused; the error's
// message starts "config: ", ready for the plugin's err text.
struct DdsConfigResult {
  DdsConfig config;
  plugin::Error error;
  [[nodiscard]] bool ok() const noexcept { return error.ok(); }
};

[[nodiscard]] DdsConfigResult parse_dds_config(std::string_view toml_text);

[[nodiscard]] std::string_view to_string(Reliability r) noexcept;
[[nodiscard]] std::string_view to_string(SamplePath p) noexcept;

}  // namespace cobridge::dds
