#include "dds/dispatcher_samples.hpp"

namespace cobridge::dds {

DispatcherSamples::DispatcherSamples(const GatewayName& gateway, bool write_batch, bool spill, std::size_t capacity)
    : gateway_(gateway), write_batch_(write_batch), spill_(spill), devices_(capacity) {}

void DispatcherSamples::device(const cobridge_device_info& info) noexcept {
  if (info.device_index >= devices_.size()) return;
  Device& d = devices_[info.device_index];
  if (info.change == COBRIDGE_DEVICE_REMOVED) {
    d = Device{};
    return;
  }
  d.name.assign(info.name);
}

void DispatcherSamples::put(const cobridge_sample& s, const Device& d, bool stale) noexcept {
  // Behind spilled samples the writer thread has not written yet: after them.
  // Behind the bus too: the writer thread batches what piles up (one sendto
  // per batch) and the dispatcher, which status samples must pass, catches up.
  if (spill_ && (spilling() || behind(s))) {
    (void)spill(s, stale);
    return;
  }
  cobridge_EncoderSample m{};
  fill_encoder_sample(m, s, gateway_, nullptr, stale);
  m.device_name = const_cast<char*>(d.name.c_str());  // Cyclone only reads it
  const dds_return_t rc = dds_write(writer_, &m);
  unflushed_ = true;
  if (rc == DDS_RETCODE_OK) {
    written_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  if (spill_ && rc == DDS_RETCODE_TIMEOUT && spill(s, stale)) return;  // history full: the writer thread waits
  failures_.fetch_add(1, std::memory_order_relaxed);
  last_failure_.store(rc, std::memory_order_relaxed);
}

bool DispatcherSamples::behind(const cobridge_sample& s) noexcept {
  return s.kind == COBRIDGE_SAMPLE_TPDO && s.publish_timestamp_ns > s.rx_timestamp_ns + kBehindNs;
}

bool DispatcherSamples::spill(const cobridge_sample& s, bool stale) noexcept {
  if (!spill_ring_.try_push(SpilledSample{s, stale})) {
    spill_drops_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  ++spilled_;
  spilled_total_.fetch_add(1, std::memory_order_relaxed);
  return true;
}

bool DispatcherSamples::write(const cobridge_sample& s) noexcept {
  if (writer_ <= 0) return true;
  static const Device kUnknown{};
  Device* d = s.device_index < devices_.size() ? &devices_[s.device_index] : nullptr;
  if (s.kind == COBRIDGE_SAMPLE_TPDO) {
    put(s, d != nullptr ? *d : kUnknown, (s.valid & COBRIDGE_VALID_STATUS) != 0 && s.stale != 0);
    if (d == nullptr) return false;
    d->last = s;
    d->has_last = true;
    const bool forward = !d->seen || d->stale;
    d->seen = true;
    d->stale = false;
    return forward;
  }
  if (s.kind == COBRIDGE_SAMPLE_STATUS && d != nullptr && (s.valid & COBRIDGE_VALID_STATUS) != 0) {
    if (s.stale != 0 && !d->stale && d->has_last) {
      // Subscribers of EncoderSample alone learn that the values they hold
      // are stale: the last values again, same sequence, flagged.
      cobridge_sample last = d->last;
      last.publish_timestamp_ns = s.publish_timestamp_ns;
      put(last, *d, true);
    }
    d->stale = s.stale != 0;
  }
  return true;
}

void DispatcherSamples::flush() noexcept {
  if (!unflushed_) return;
  if (write_batch_) (void)dds_write_flush(writer_);
  unflushed_ = false;
}

}  // namespace cobridge::dds
