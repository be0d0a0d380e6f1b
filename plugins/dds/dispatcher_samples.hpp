// DispatcherSamples: EncoderSample written on the dispatcher thread itself
// (sample_path "auto", the default, and "dispatcher"; docs/dds.md, "Threads
// and cost").
//
// Why: writing there saves the hand-over to the plugin's writer thread,
// whose wake-up and context switch dominate the tail when the dispatcher,
// the writer thread and a subscriber share cores (docs/performance-notes.md,
// "DDS latency"). It cannot stall the dispatcher: a best-effort KEEP_LAST writer
// never waits, and the sample writer has max_blocking_time 0, so a reliable
// write that finds the history cache full (a reader that acknowledges too
// slowly; WhcHigh) fails at once with DDS_RETCODE_TIMEOUT. Then:
//   - "dispatcher": the write is counted as failed, the subscriber sees a gap;
//   - "auto" (spill): the sample goes to the spill ring instead, and so does
//     every EncoderSample after it until the writer thread has written all
//     of them (order kept), waiting up to kMaxBlocking for room each, like
//     the writer-thread path. A reader that keeps up costs the direct path's
//     latency; one that lags gets the writer thread's patience; a spill ring
//     that is full drops and counts. A TPDO the dispatcher hands over more
//     than kBehindNs after its frame arrived spills too: the dispatcher is
//     behind (a CPU too slow for a dds_write and, with small batches, a
//     sendto per sample: measured in UML), and every status sample waits
//     behind it in the daemon's rings; the writer thread writes the backlog
//     in large batches and the plugin's status lane goes past it.
// With write_batch, one dds_write_flush per on_samples call sends the batch
// as one RTPS message.
//
// What stays on the writer thread (DdsPublisher): EncoderEvent and
// DeviceStatus (reliable: they can block). The writer thread still needs a
// TPDO now and then for DeviceStatus (the first TPDO of a device makes it
// known; a TPDO after a stale declaration clears `stale`): forward() says
// which TPDOs to queue for it. The stale re-publication of the last values is
// done here, where the last values are, when a STATUS sample says stale.
//
// Per sample: no allocation, no lock of ours, no exception, no logging; the
// only syscall is Cyclone's sendto (one per flush with write_batch).
//
// Thread contract: attach/detach on the control thread while the dispatcher
// does not call in (plugin start/stop); device/write/flush on the dispatcher
// thread only; take_spilled/spilled_done on the writer thread only; stats
// from any thread.
#pragma once

#include "dds/device_slots.hpp"
#include "dds/sample_mapping.hpp"

#include <cobridge/plugin.h>
#include <cobridge/spsc_ring.hpp>
#include <dds/dds.h>

#include <atomic>
#include <cstdint>
#include <span>
#include <vector>

namespace cobridge::dds {

// An EncoderSample the dispatcher could not write, for the writer thread.
struct SpilledSample {
  cobridge_sample sample;
  bool stale;  // the value of EncoderSample.stale
};

class DispatcherSamples {
 public:
  static constexpr std::size_t kSpill = 1u << 15;  // 8 s of four devices at 1 kHz
  // Frame to dispatcher beyond this: behind. The direct path's p99.9 on a
  // loaded 2-core host is ~0.2 ms (docs/performance-notes.md, "DDS latency").
  static constexpr std::uint64_t kBehindNs = 2'000'000;

  // `spill`: a write that finds the reliable history full goes to the writer
  // thread (sample_path "auto") instead of failing ("dispatcher").
  DispatcherSamples(const GatewayName& gateway, bool write_batch, bool spill,
                    std::size_t capacity = DeviceSlots::kDefaultCapacity);

  void attach(dds_entity_t sample_writer) noexcept { writer_ = sample_writer; }
  void detach() noexcept { writer_ = 0; }
  [[nodiscard]] bool attached() const noexcept { return writer_ > 0; }

  // Keeps the device's name for its samples (on_device).
  void device(const cobridge_device_info& info) noexcept;

  // Writes what EncoderSample shows of `s` (a TPDO; the stale re-publication
  // on a STATUS that turns the device stale). Returns whether the writer
  // thread must see `s` too: every non-TPDO sample, and the TPDOs that change
  // DeviceStatus (a device's first; the first after stale).
  [[nodiscard]] bool write(const cobridge_sample& s) noexcept;
  // Sends what write() queued (write_batch); once per on_samples call.
  void flush() noexcept;
  // Whether samples wait in the spill ring (the writer thread must be woken).
  [[nodiscard]] bool spilling() const noexcept { return spilled_ != spill_done_.load(std::memory_order_acquire); }

  // Writer thread: the spilled samples in order; then, once written (or
  // failed), spilled_done(n) lets the dispatcher write directly again when
  // none is left.
  [[nodiscard]] std::size_t take_spilled(std::span<SpilledSample> out) noexcept { return spill_ring_.pop_batch(out); }
  void spilled_done(std::size_t n) noexcept { spill_done_.fetch_add(n, std::memory_order_release); }

  [[nodiscard]] std::uint64_t written() const noexcept { return written_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::uint64_t failures() const noexcept { return failures_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::int32_t last_failure() const noexcept { return last_failure_.load(std::memory_order_relaxed); }
  // Samples handed to the writer thread / dropped because its ring was full.
  [[nodiscard]] std::uint64_t spilled() const noexcept { return spilled_total_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::uint64_t spill_drops() const noexcept { return spill_drops_.load(std::memory_order_relaxed); }

 private:
  struct Device {
    bool seen = false;   // a TPDO was forwarded to the writer thread
    bool stale = false;  // a STATUS said stale and no TPDO came since
    bool has_last = false;
    FixedString<64> name;
    cobridge_sample last{};
  };
  void put(const cobridge_sample& s, const Device& d, bool stale) noexcept;
  // A TPDO handed out more than kBehindNs after its frame arrived.
  static bool behind(const cobridge_sample& s) noexcept;
  // Into the spill ring; false (counted) when it is full.
  bool spill(const cobridge_sample& s, bool stale) noexcept;

  GatewayName gateway_;
  bool write_batch_;
  bool spill_;
  dds_entity_t writer_ = 0;
  bool unflushed_ = false;
  std::vector<Device> devices_;  // by device_index, allocated once
  SpscRing<SpilledSample> spill_ring_{kSpill};
  std::uint64_t spilled_ = 0;                // dispatcher: pushed to the spill ring
  std::atomic<std::uint64_t> spill_done_{0}; // writer thread: of those, written or failed
  std::atomic<std::uint64_t> written_{0}, failures_{0}, spilled_total_{0}, spill_drops_{0};
  std::atomic<std::int32_t> last_failure_{0};
};

}  // namespace cobridge::dds
