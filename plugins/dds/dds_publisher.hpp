// DdsPublisher: the DDS side of the plugin. Owns one participant in the
// configured domain, the three topics and their writers, and turns the
// dispatcher's samples and device announcements into DDS writes:
//   TPDO                         -> EncoderSample
//   EMCY                         -> EncoderEvent (decoded text), DeviceStatus
//   HEARTBEAT, NMT_STATE, STATUS -> DeviceStatus when what it shows changed;
//                                   on turning stale also the last
//                                   EncoderSample again, with stale = true.
//
// Samples are written straight from the dispatcher thread with dds_write:
// Cyclone's write is thread-safe, serializes into its own buffers and hands
// the data to the network without waiting for readers (best-effort); a
// reliable writer waits at most kMaxBlocking for history room. The structs
// are filled on the stack and point at the slot table (no allocation here).
//
// Thread contract: start/stop on the control thread; publish/device on the
// dispatcher thread between start and stop; stats from any thread.
#pragma once

#include "dds/dds_config.hpp"
#include "dds/device_slots.hpp"

#include <cobridge/plugin.h>
#include <dds/dds.h>

#include <atomic>
#include <cstdint>
#include <span>
#include <string>
#include <system_error>

namespace cobridge::dds {

// Cyclone DDS return codes (DDS_RETCODE_*, negated as in dds_return_t).
[[nodiscard]] const std::error_category& dds_category() noexcept;
[[nodiscard]] std::error_code make_dds_error(dds_return_t rc) noexcept;

struct PublisherStats {
  std::uint64_t samples = 0;        // EncoderSample writes
  std::uint64_t events = 0;         // EncoderEvent writes
  std::uint64_t statuses = 0;       // DeviceStatus writes
  std::uint64_t write_failures = 0; // dds_write errors (incl. reliable timeouts)
  std::int32_t last_failure = 0;    // dds_return_t of the last failure
  std::uint64_t unknown_kind = 0;   // samples of a kind this version ignores
};

class DdsPublisher {
 public:
  DdsPublisher(DdsConfig config, std::string gateway_id);
  ~DdsPublisher();
  DdsPublisher(const DdsPublisher&) = delete;
  DdsPublisher& operator=(const DdsPublisher&) = delete;

  // Creates the participant, topics and writers, then publishes the
  // DeviceStatus of every device already known. On failure nothing is left
  // and `message` says which step failed.
  [[nodiscard]] std::error_code start(std::string& message);
  void stop() noexcept;
  [[nodiscard]] bool started() const noexcept { return participant_ > 0; }

  void publish(std::span<const cobridge_sample> samples) noexcept;
  void device(const cobridge_device_info& info) noexcept;

  [[nodiscard]] PublisherStats stats() const noexcept;
  [[nodiscard]] const DdsConfig& config() const noexcept { return config_; }

 private:
  void publish_one(const cobridge_sample& s) noexcept;
  void write_status(const DeviceSlot& slot) noexcept;
  void write(dds_entity_t writer, const void* data, std::atomic<std::uint64_t>& counter) noexcept;
  void forget_instance(const DeviceSlot& slot) noexcept;

  DdsConfig config_;
  std::string gateway_id_;
  DeviceSlots slots_;
  dds_entity_t participant_ = 0;
  dds_entity_t sample_writer_ = 0;
  dds_entity_t event_writer_ = 0;
  dds_entity_t status_writer_ = 0;
  std::atomic<std::uint64_t> samples_{0}, events_{0}, statuses_{0}, failures_{0}, unknown_kind_{0};
  std::atomic<std::int32_t> last_failure_{0};
};

}  // namespace cobridge::dds
