// DdsPublisher: the DDS side of the plugin. Owns its Cyclone domain (when
// the process has none for that id yet), one participant in it, the three
// topics and their writers, and turns samples and device announcements into
// DDS writes:
//   TPDO                         -> EncoderSample
//   EMCY                         -> EncoderEvent (decoded text), DeviceStatus
//   HEARTBEAT, NMT_STATE, STATUS -> DeviceStatus when what it shows changed;
//                                   on turning stale also the last
//                                   EncoderSample again, with stale = true.
// With config.samples_on_dispatcher() EncoderSample is DispatcherSamples'
// (dispatcher_samples.hpp): publish() then only keeps DeviceStatus current
// from the TPDOs it is given.
//
// The structs are filled on the stack and point at the slot table (the
// plugin allocates nothing per sample; Cyclone's dds_write does, see
// docs/performance.md). A reliable writer waits at most kMaxBlocking for
// history room. With write_batch, dds_write only queues the sample in the
// writer's RTPS message and publish()/device() send what they wrote with
// one dds_write_flush per writer, so a batch of samples costs one sendto.
//
// Status ahead of samples: publish_status() takes the status
// samples (heartbeat, NMT state, STATUS) of the plugin's status lane before
// the sample queue reaches them, so DeviceStatus and the GatewayStatus counts
// follow a device going offline at once even with seconds of EncoderSamples
// queued (device_slots.hpp says how the queue then skips them).
//
// Thread contract: start/stop on the control thread; publish, write_samples,
// publish_status, flush and device on the plugin's writer thread (one
// thread) between start and stop; stats and counts from any thread.
#pragma once

#include "dds/dds_config.hpp"
#include "dds/device_slots.hpp"
#include "dds/gateway_presence.hpp"
#include "dds/sample_mapping.hpp"

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

  // Creates the domain (with write_batch: Cyclone's WriteBatch followed by
  // the user's CYCLONEDDS_URI, so the user's settings still apply and win),
  // the participant (secured with config.security: dds_security.hpp),
  // topics and writers, then publishes the DeviceStatus of
  // every device already known. On failure nothing is left; the error's
  // message says which step failed and its code is Cyclone's return code
  // (dds_category). `note` is set when start succeeded but write_batch could
  // not be applied (the process already had the domain).
  [[nodiscard]] plugin::Error start(std::string& note);
  void stop() noexcept;
  [[nodiscard]] bool started() const noexcept { return participant_ > 0; }

  // Both write, then flush what they wrote (write_batch).
  void publish(std::span<const cobridge_sample> samples) noexcept;
  void device(const cobridge_device_info& info) noexcept;
  // publish() without the flush: the caller flushes (or publish_status does).
  void write_samples(std::span<const cobridge_sample> samples) noexcept;
  // Status samples from the status lane, ahead of the queue (each one also
  // comes through publish() later, in order): DeviceStatus written for every
  // change, then everything written so far is flushed.
  void publish_status(std::span<const cobridge_sample> samples) noexcept;
  // Sends what was written since the last flush (write_batch).
  void flush() noexcept;
  // An EncoderSample the dispatcher could not write (DispatcherSamples'
  // spill ring): a full reliable history is waited for up to `patience`
  // (the sample writer itself has max_blocking_time 0 then), in short
  // sleeps; what still finds no room is counted as a failure.
  void write_spilled(const cobridge_sample& s, bool stale, dds_duration_t patience) noexcept;

  [[nodiscard]] PublisherStats stats() const noexcept;
  // Any thread while started (the status page): the data writers this
  // publisher made, and the readers matched to them now (Cyclone's
  // publication-matched status, summed).
  struct WriterCounts {
    std::uint32_t writers = 0;
    std::uint32_t matched_readers = 0;
  };
  [[nodiscard]] WriterCounts writer_counts() const noexcept;
  [[nodiscard]] const DdsConfig& config() const noexcept { return config_; }
  [[nodiscard]] dds_entity_t participant() const noexcept { return participant_; }
  // The EncoderSample writer, for DispatcherSamples (0 before start).
  [[nodiscard]] dds_entity_t sample_writer() const noexcept { return sample_writer_; }
  [[nodiscard]] const GatewayName& gateway() const noexcept { return gateway_; }
  // Hot standby: the ownership strength of the three data writers (their
  // ownership is EXCLUSIVE when config().redundancy_node is set). Any thread
  // while started; Cyclone announces the change to the readers.
  // A failure has Cyclone's return code (dds_category) and says which step.
  [[nodiscard]] plugin::Error set_ownership_strength(std::int32_t strength);
  // Device and bus counts as of the last status change (any thread).
  [[nodiscard]] GatewayCounts counts() const noexcept;

 private:
  void publish_one(const cobridge_sample& s) noexcept;
  void write_status(const DeviceSlot& slot) noexcept;
  void write(dds_entity_t writer, const void* data, std::atomic<std::uint64_t>& counter) noexcept;
  // Counts a write's outcome: `counter` on success, a failure otherwise.
  void tally(dds_return_t rc, std::atomic<std::uint64_t>& counter) noexcept;
  void forget_instance(const DeviceSlot& slot) noexcept;
  // The domain with WriteBatch (start, when config_.write_batch).
  [[nodiscard]] plugin::Error create_domain(dds_domainid_t domain, std::string& note);
  // The topics and their writers under publisher_ (start).
  [[nodiscard]] plugin::Error create_writers();
  // The participant of config_.domain, secured with config_.security (start).
  [[nodiscard]] plugin::Error create_participant(dds_domainid_t domain);
  // With DDS Security on: what to add to a failed creation's message.
  [[nodiscard]] std::string security_hint(dds_return_t rc) const;
  // STATUS in queue order: the last EncoderSample again, stale, when the
  // device turns stale (subscribers of EncoderSample alone learn it).
  void republish_if_stale(DeviceSlot& slot, const cobridge_sample& status) noexcept;
  // Recounts devices and buses after a status change (writer thread).
  void recount() noexcept;

  DdsConfig config_;
  std::string gateway_id_;
  GatewayName gateway_;  // points into gateway_id_
  DeviceSlots slots_;
  dds_entity_t domain_ = 0;  // > 0 when this publisher created the domain
  dds_entity_t participant_ = 0;
  dds_entity_t publisher_ = 0;  // of config_.partition
  dds_entity_t sample_writer_ = 0;
  dds_entity_t event_writer_ = 0;
  dds_entity_t status_writer_ = 0;
  // Writers with samples queued since the last flush (kFlush* bits).
  std::uint8_t unflushed_ = 0;
  std::atomic<std::uint64_t> samples_{0}, events_{0}, statuses_{0}, failures_{0}, unknown_kind_{0};
  std::atomic<std::int32_t> last_failure_{0};
  std::atomic<std::uint64_t> counts_{0};  // GatewayCounts packed 4 x 16 bits
};

}  // namespace cobridge::dds
