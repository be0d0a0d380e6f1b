#include "canopen/sync.hpp"

#include <string>

namespace cobridge::canopen {

std::string_view to_string(SyncFrameError error) noexcept {
  switch (error) {
    case SyncFrameError::none: return "ok";
    case SyncFrameError::wrong_cob_id: return "not the SYNC COB-ID";
    case SyncFrameError::wrong_length: return "unexpected SYNC data length";
    case SyncFrameError::remote_request: return "unexpected remote request";
    case SyncFrameError::counter_out_of_range: return "SYNC counter outside 1..240";
  }
  return "unknown error";
}

SyncParse parse_sync(const can::Frame& frame, uint32_t cob_id) noexcept {
  SyncParse r;
  if (frame.is_extended() || frame.id != cob_id) {
    r.error = SyncFrameError::wrong_cob_id;
  } else if (frame.is_rtr()) {
    r.error = SyncFrameError::remote_request;
  } else if (frame.len > 1) {
    r.error = SyncFrameError::wrong_length;
  } else if (frame.len == 1) {
    if (frame.data[0] == 0 || frame.data[0] > 240) {
      r.error = SyncFrameError::counter_out_of_range;
    } else {
      r.message.has_counter = true;
      r.message.counter = frame.data[0];
    }
  }
  return r;
}

bool matches_overflow(const SyncMessage& message, uint8_t overflow) noexcept {
  if (overflow == 0) return !message.has_counter;
  return message.has_counter && message.counter <= overflow;
}

namespace {

class SyncCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "cobridge.sync"; }
  std::string message(int ev) const override {
    switch (static_cast<SyncConfigErrc>(ev)) {
      case SyncConfigErrc::zero_period: return "SYNC period must be positive";
      case SyncConfigErrc::invalid_overflow:
        return "synchronous counter overflow must be 0 or 2..240 (CiA 301 0x1019)";
      case SyncConfigErrc::invalid_cob_id: return "SYNC COB-ID must be an 11-bit identifier";
    }
    return "unknown SYNC configuration error";
  }
};

}  // namespace

const std::error_category& sync_category() noexcept {
  static const SyncCategory category;
  return category;
}

std::error_code make_error_code(SyncConfigErrc e) noexcept {
  return {static_cast<int>(e), sync_category()};
}

std::error_code SyncProducer::configure(const Config& config) noexcept {
  running_ = false;
  configured_ = false;
  if (config.period <= Duration::zero()) return SyncConfigErrc::zero_period;
  if (config.overflow == 1 || config.overflow > 240) return SyncConfigErrc::invalid_overflow;
  if (config.cob_id > 0x7FF) return SyncConfigErrc::invalid_cob_id;
  config_ = config;
  configured_ = true;
  return {};
}

void SyncProducer::start(TimePoint now) noexcept {
  if (!configured_) return;
  running_ = true;
  counter_ = 1;
  next_ = now + config_.period;
}

TimePoint SyncProducer::process(TimePoint now, can::FrameSink& sink) noexcept {
  if (!running_) return kNever;
  if (now < next_) return next_;

  can::Frame f;
  f.id = config_.cob_id;
  if (config_.overflow != 0) {
    f.len = 1;
    f.data[0] = counter_;
  }
  if (sink.send(f)) {
    ++sent_;
    // Only a SYNC that went out advances the counter, so consumers never
    // see a gap in it.
    if (config_.overflow != 0) counter_ = counter_ >= config_.overflow ? uint8_t{1} : static_cast<uint8_t>(counter_ + 1);
  } else {
    ++send_failures_;
  }

  next_ += config_.period;
  if (next_ <= now) {
    // Late by more than a period: keep the grid, skip the missed SYNCs.
    const auto behind = (now - next_) / config_.period + 1;
    next_ += config_.period * behind;
  }
  return next_;
}

}  // namespace cobridge::canopen
