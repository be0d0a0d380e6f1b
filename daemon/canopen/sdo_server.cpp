#include "canopen/sdo_server.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <span>

#include "canopen/cob_id.hpp"
#include "canopen/sdo_protocol.hpp"

namespace cobridge::canopen {

using namespace sdo_protocol;  // NOLINT(google-build-using-namespace): the frame layout's vocabulary

namespace {

// Responses: byte 0 with the server command specifier and no flag bits.
constexpr uint8_t kUploadSegmentResponse = command(kScsUploadSegment);
constexpr uint8_t kDownloadSegmentResponse = command(kScsDownloadSegment);
constexpr uint8_t kUploadInitiateResponse = command(kScsUploadInitiate);
constexpr uint8_t kDownloadInitiateResponse = command(kScsDownloadInitiate);
constexpr uint8_t kAbortFrame = command(kCsAbort);

}  // namespace

SdoServer::SdoServer(can::FrameSink& sink, ObjectDictionary& od, uint8_t node_id, Config config)
    : sink_(sink), od_(od), config_(config), node_id_(node_id) {
  const size_t size =
      config_.buffer_size != 0 ? config_.buffer_size : std::max(kExpeditedMax, od_.max_value_size());
  buffer_.resize(size);
}

void SdoServer::set_node_id(uint8_t node_id) noexcept {
  node_id_ = node_id;
  reset();
}

void SdoServer::set_enabled(bool enabled) noexcept {
  enabled_ = enabled;
  if (!enabled_) reset();
}

void SdoServer::reset() noexcept {
  state_ = State::kIdle;
  toggle_ = false;
  size_indicated_ = false;
  total_ = 0;
  done_ = 0;
  limit_ = 0;
  deadline_ = kNever;
}

uint32_t SdoServer::map_code(uint32_t code) const noexcept {
  const bool length_code = code == od_abort::kLengthMismatch || code == od_abort::kLengthTooHigh ||
                           code == od_abort::kLengthTooLow;
  return (length_code && config_.length_abort_override != 0) ? config_.length_abort_override : code;
}

void SdoServer::send(const std::array<uint8_t, 8>& bytes) noexcept {
  if (!sink_.send(can::Frame::make8(cob::kSdoTxBase + node_id_, bytes))) ++tx_failures_;
}

void SdoServer::send_abort(uint16_t index, uint8_t sub, uint32_t code) noexcept {
  auto b = multiplexed(kAbortFrame, index, sub);
  write_u32le(b, 4, map_code(code));
  send(b);
}

bool SdoServer::on_frame(const can::Frame& frame, TimePoint now) noexcept {
  if (!enabled_) return false;
  if (frame.id != cob::kSdoRxBase + node_id_ || frame.is_rtr() || frame.is_extended() || frame.is_error())
    return false;
  if (frame.len != 8) return true;  // CiA 301: SDO frames are 8 bytes; see header

  switch (specifier(frame.data[0])) {
    case kCcsDownloadSegment: download_segment(frame, now); break;
    case kCcsDownloadInitiate: initiate_download(frame, now); break;
    case kCcsUploadInitiate: initiate_upload(frame, now); break;
    case kCcsUploadSegment: upload_segment(frame, now); break;
    case kCsAbort: reset(); break;
    default:
      // 5 = block upload, 6 = block download, 7 = undefined. Bytes 1..3 of a
      // block initiate carry the multiplexer, so echo them.
      reset();
      send_abort(index_of(frame.data), frame.data[3], od_abort::kCommandSpecifierInvalid);
      break;
  }
  return true;
}

TimePoint SdoServer::process(TimePoint now) noexcept {
  if (!enabled_ || state_ == State::kIdle) return kNever;
  if (now >= deadline_) {
    send_abort(index_, sub_, od_abort::kSdoProtocolTimedOut);
    reset();
    return kNever;
  }
  return deadline_;
}

// CiA 301 §7.2.4.3.3: initiate download, expedited or segmented.
void SdoServer::initiate_download(const can::Frame& f, TimePoint now) noexcept {
  const uint16_t index = index_of(f.data);
  const uint8_t sub = f.data[3];
  const uint8_t cmd = f.data[0];
  reset();

  if ((cmd & kBitExpedited) != 0) {
    size_t size = kExpeditedMax;
    if ((cmd & kBitSizeIndicated) != 0) {
      size = kExpeditedMax - ((cmd >> 2U) & 0x03U);
    } else if (const auto info = od_.info(index, sub); info && !info->is_string && info->size < kExpeditedMax) {
      // 0x22: size not indicated; the four data bytes hold the value and any
      // padding, so take as many as the object is long.
      size = info->size;
    }
    const uint32_t code = od_.write(index, sub, std::span<const uint8_t>(f.data.data() + 4, size));
    if (code != od_abort::kNone) {
      send_abort(index, sub, code);
      return;
    }
    send(multiplexed(kDownloadInitiateResponse, index, sub));
    return;
  }

  if (!config_.segmented) {
    send_abort(index, sub, config_.segmented_disabled_abort);
    return;
  }
  const uint32_t code = od_.check_writable(index, sub);
  if (code != od_abort::kNone) {
    send_abort(index, sub, code);
    return;
  }
  const auto info = od_.info(index, sub);  // present: check_writable passed
  limit_ = info ? info->capacity : 0;
  size_indicated_ = (cmd & kBitSizeIndicated) != 0;
  total_ = size_indicated_ ? read_u32le(f.data, 4) : 0;
  if (size_indicated_ && total_ > limit_) {
    send_abort(index, sub, od_abort::kLengthTooHigh);
    reset();
    return;
  }
  if (size_indicated_ && total_ > buffer_.size()) {
    send_abort(index, sub, od_abort::kOutOfMemory);
    reset();
    return;
  }
  state_ = State::kDownloading;
  index_ = index;
  sub_ = sub;
  toggle_ = false;
  done_ = 0;
  deadline_ = now + config_.segment_timeout;
  send(multiplexed(kDownloadInitiateResponse, index, sub));
}

// CiA 301 §7.2.4.3.4: download segment.
void SdoServer::download_segment(const can::Frame& f, TimePoint now) noexcept {
  if (state_ != State::kDownloading) {
    const bool uploading = state_ == State::kUploading;
    const uint16_t index = uploading ? index_ : 0;
    const uint8_t sub = uploading ? sub_ : 0;
    reset();
    send_abort(index, sub, od_abort::kCommandSpecifierInvalid);
    return;
  }
  const uint8_t cmd = f.data[0];
  const bool toggle = (cmd & kBitToggle) != 0;
  if (toggle != toggle_) {
    send_abort(index_, sub_, od_abort::kToggleBitNotAlternated);
    reset();
    return;
  }
  const size_t count = kSegmentMax - ((cmd >> 1U) & 0x07U);
  const bool last = (cmd & kBitLastSegment) != 0;
  if (done_ + count > limit_ || (size_indicated_ && done_ + count > total_)) {
    send_abort(index_, sub_, size_indicated_ && done_ + count > total_ ? od_abort::kLengthMismatch
                                                                        : od_abort::kLengthTooHigh);
    reset();
    return;
  }
  if (done_ + count > buffer_.size()) {
    send_abort(index_, sub_, od_abort::kOutOfMemory);
    reset();
    return;
  }
  std::memcpy(buffer_.data() + done_, f.data.data() + 1, count);
  done_ += count;
  const uint8_t response = static_cast<uint8_t>(kDownloadSegmentResponse | (toggle ? kBitToggle : 0U));

  if (!last) {
    toggle_ = !toggle_;
    deadline_ = now + config_.segment_timeout;
    send({response, 0, 0, 0, 0, 0, 0, 0});
    return;
  }
  const uint16_t index = index_;
  const uint8_t sub = sub_;
  const bool short_of_announced = size_indicated_ && done_ != total_;
  const size_t size = done_;
  reset();
  if (short_of_announced) {
    send_abort(index, sub, od_abort::kLengthMismatch);
    return;
  }
  const uint32_t code = od_.write(index, sub, std::span<const uint8_t>(buffer_.data(), size));
  if (code != od_abort::kNone) {
    send_abort(index, sub, code);
    return;
  }
  send({response, 0, 0, 0, 0, 0, 0, 0});
}

// CiA 301 §7.2.4.3.6: initiate upload; expedited when the value fits in 4 bytes.
void SdoServer::initiate_upload(const can::Frame& f, TimePoint now) noexcept {
  const uint16_t index = index_of(f.data);
  const uint8_t sub = f.data[3];
  reset();

  const ReadResult r = od_.read(index, sub, std::span<uint8_t>(buffer_));
  if (r.abort_code != od_abort::kNone) {
    send_abort(index, sub, r.abort_code);
    return;
  }
  if (r.size >= 1 && r.size <= kExpeditedMax) {
    const uint8_t cmd = config_.respond_size_indicated
                            ? static_cast<uint8_t>(kUploadInitiateResponse | ((kExpeditedMax - r.size) << 2U) |
                                                   kBitExpedited | kBitSizeIndicated)
                            : static_cast<uint8_t>(kUploadInitiateResponse | kBitExpedited);
    auto b = multiplexed(cmd, index, sub);
    std::memcpy(b.data() + 4, buffer_.data(), r.size);
    send(b);
    return;
  }
  // Longer than 4 bytes, or empty (an expedited response cannot say "0 bytes").
  if (!config_.segmented) {
    send_abort(index, sub, config_.segmented_disabled_abort);
    return;
  }
  state_ = State::kUploading;
  index_ = index;
  sub_ = sub;
  total_ = r.size;
  done_ = 0;
  toggle_ = false;
  deadline_ = now + config_.segment_timeout;
  auto b = multiplexed(config_.respond_size_indicated
                           ? static_cast<uint8_t>(kUploadInitiateResponse | kBitSizeIndicated)
                           : kUploadInitiateResponse,
                       index, sub);
  if (config_.respond_size_indicated) write_u32le(b, 4, static_cast<uint32_t>(r.size));
  send(b);
}

// CiA 301 §7.2.4.3.7: upload segment.
void SdoServer::upload_segment(const can::Frame& f, TimePoint now) noexcept {
  if (state_ != State::kUploading) {
    const bool downloading = state_ == State::kDownloading;
    const uint16_t index = downloading ? index_ : 0;
    const uint8_t sub = downloading ? sub_ : 0;
    reset();
    send_abort(index, sub, od_abort::kCommandSpecifierInvalid);
    return;
  }
  const bool toggle = (f.data[0] & kBitToggle) != 0;
  if (toggle != toggle_) {
    send_abort(index_, sub_, od_abort::kToggleBitNotAlternated);
    reset();
    return;
  }
  const size_t count = std::min(kSegmentMax, total_ - done_);
  const bool last = done_ + count == total_;
  std::array<uint8_t, 8> b{};
  b[0] = static_cast<uint8_t>(kUploadSegmentResponse | (toggle ? kBitToggle : 0U) | ((kSegmentMax - count) << 1U) |
                              (last ? kBitLastSegment : 0U));
  std::memcpy(b.data() + 1, buffer_.data() + done_, count);
  done_ += count;
  if (last) {
    reset();
  } else {
    toggle_ = !toggle_;
    deadline_ = now + config_.segment_timeout;
  }
  send(b);
}

}  // namespace cobridge::canopen
