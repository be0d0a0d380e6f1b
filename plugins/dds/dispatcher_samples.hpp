// DispatcherSamples: EncoderSample written on the dispatcher thread itself,
// for a best-effort sample writer (sample_path = "dispatcher", the default
// for best-effort; docs/dds.md, "Threads and cost").
//
// Why: a best-effort KEEP_LAST writer never waits for history room or
// acknowledgements, so dds_write cannot stall the dispatcher (a reliable one,
// with sample_path = "dispatcher", gets max_blocking_time 0: when its
// history cache is full the write fails at once, is counted, and the
// subscriber sees the gap); writing there
// saves the hand-over to the plugin's writer thread, whose wake-up and
// context switch dominate the tail when the dispatcher, the writer thread and
// a subscriber share cores (docs/performance.md, "DDS latency"). With
// write_batch, one dds_write_flush per on_samples call sends the batch as one
// RTPS message.
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
// thread only; stats from any thread.
#pragma once

#include "dds/device_slots.hpp"
#include "dds/sample_mapping.hpp"

#include <cobridge/plugin.h>
#include <dds/dds.h>

#include <atomic>
#include <cstdint>
#include <span>
#include <vector>

namespace cobridge::dds {

class DispatcherSamples {
 public:
  DispatcherSamples(const GatewayName& gateway, bool write_batch,
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

  [[nodiscard]] std::uint64_t written() const noexcept { return written_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::uint64_t failures() const noexcept { return failures_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::int32_t last_failure() const noexcept { return last_failure_.load(std::memory_order_relaxed); }

 private:
  struct Device {
    bool seen = false;   // a TPDO was forwarded to the writer thread
    bool stale = false;  // a STATUS said stale and no TPDO came since
    bool has_last = false;
    FixedString<64> name;
    cobridge_sample last{};
  };
  void put(const cobridge_sample& s, const Device& d, bool stale) noexcept;

  GatewayName gateway_;
  bool write_batch_;
  dds_entity_t writer_ = 0;
  bool unflushed_ = false;
  std::vector<Device> devices_;  // by device_index, allocated once
  std::atomic<std::uint64_t> written_{0}, failures_{0};
  std::atomic<std::int32_t> last_failure_{0};
};

}  // namespace cobridge::dds
