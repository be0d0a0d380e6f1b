#include "canopen/sdo_client.hpp"

#include <algorithm>
#include <cstring>

#include "canopen/cob_id.hpp"
#include "canopen/sdo_protocol.hpp"

namespace cobridge::canopen {

using namespace sdo_protocol;  // NOLINT(google-build-using-namespace): the frame layout's vocabulary

namespace {

constexpr std::size_t kMinBuffer = 8;

// An initiate-type or abort frame: command, index (LE), sub-index, 4 data bytes.
can::Frame multiplexed_frame(uint32_t cob_id, uint8_t byte0, uint16_t index, uint8_t sub) noexcept {
  return can::Frame::make8(cob_id, multiplexed(byte0, index, sub));
}

}  // namespace

// --- Result decoding -------------------------------------------------------

uint32_t SdoClient::Result::as_u32() const noexcept {
  uint32_t v = 0;
  const std::size_t n = std::min<std::size_t>(data.size(), 4);
  for (std::size_t i = 0; i < n; ++i) v |= static_cast<uint32_t>(data[i]) << (8 * i);
  return v;
}

int32_t SdoClient::Result::as_i32() const noexcept {
  const std::size_t n = std::min<std::size_t>(data.size(), 4);
  uint32_t v = as_u32();
  if (n > 0 && n < 4) {
    const uint32_t sign = 1u << (8 * n - 1);
    if ((v & sign) != 0) v |= ~((sign << 1) - 1u);
  }
  return static_cast<int32_t>(v);
}

std::string_view SdoClient::Result::as_string() const noexcept {
  const auto* p = reinterpret_cast<const char*>(data.data());
  std::string_view s(p, data.size());
  const auto nul = s.find('\0');
  return nul == std::string_view::npos ? s : s.substr(0, nul);
}

// --- SdoClient ----------------------------------------------------------------

SdoClient::SdoClient(can::FrameSink& sink, uint8_t node_id, Config cfg)
    : sink_(sink), node_id_(node_id), cfg_(cfg) {
  // Expedited answers are written into the buffer too, so it holds at least a
  // whole frame's worth.
  cfg_.buffer_size = std::max(cfg_.buffer_size, kMinBuffer);
  buffer_ = std::make_unique<uint8_t[]>(cfg_.buffer_size);
}

std::error_code SdoClient::set_node_id(uint8_t node_id) noexcept {
  if (busy()) return std::make_error_code(std::errc::device_or_resource_busy);
  if (!cob::valid_node_id(node_id)) return std::make_error_code(std::errc::invalid_argument);
  node_id_ = node_id;
  return {};
}

uint32_t SdoClient::request_cob_id() const noexcept { return cob::kSdoRxBase + node_id_; }
uint32_t SdoClient::response_cob_id() const noexcept { return cob::kSdoTxBase + node_id_; }

std::error_code SdoClient::start_upload(uint16_t index, uint8_t sub, TimePoint now) noexcept {
  if (busy()) return std::make_error_code(std::errc::device_or_resource_busy);
  if (!cob::valid_node_id(node_id_)) return std::make_error_code(std::errc::invalid_argument);
  result_.reset();
  const can::Frame req = multiplexed_frame(request_cob_id(), command(kCcsUploadInitiate), index, sub);
  if (!send(req)) return std::make_error_code(std::errc::no_buffer_space);
  size_ = 0;
  size_indicated_ = false;
  begin_transfer(req, index, sub, State::kUploadInitiate, now);
  return {};
}

std::error_code SdoClient::start_download(uint16_t index, uint8_t sub, std::span<const uint8_t> data,
                                          TimePoint now) noexcept {
  if (busy()) return std::make_error_code(std::errc::device_or_resource_busy);
  if (!cob::valid_node_id(node_id_)) return std::make_error_code(std::errc::invalid_argument);
  if (data.size() > cfg_.buffer_size) return std::make_error_code(std::errc::value_too_large);
  result_.reset();

  can::Frame req;
  const bool expedited = !data.empty() && data.size() <= kExpeditedMax;
  if (expedited) {
    // n = number of bytes in d[4..7] that carry no data: 4 bytes -> 0x23,
    // 3 -> 0x27, 2 -> 0x2B, 1 -> 0x2F (J§1.6, E§7.1, F§7).
    const auto n = static_cast<uint8_t>(kExpeditedMax - data.size());
    const auto byte0 = static_cast<uint8_t>(command(kCcsDownloadInitiate) | (n << 2) | kBitExpedited |
                                            kBitSizeIndicated);
    req = multiplexed_frame(request_cob_id(), byte0, index, sub);
    std::copy(data.begin(), data.end(), req.data.begin() + 4);
  } else {
    // Segmented with the size announced (0x21), also for 0 bytes, which
    // cannot be expressed expedited (n has only two bits).
    req = multiplexed_frame(request_cob_id(), static_cast<uint8_t>(command(kCcsDownloadInitiate) | kBitSizeIndicated),
                            index, sub);
    write_u32le(req.data, 4, static_cast<uint32_t>(data.size()));
  }
  if (!send(req)) return std::make_error_code(std::errc::no_buffer_space);

  std::copy(data.begin(), data.end(), buffer_.get());
  size_ = data.size();
  segment_bytes_ = 0;
  last_segment_sent_ = expedited;
  begin_transfer(req, index, sub, State::kDownloadInitiate, now);
  return {};
}

void SdoClient::begin_transfer(const can::Frame& request, uint16_t index, uint8_t sub, State state,
                               TimePoint now) noexcept {
  index_ = index;
  sub_ = sub;
  offset_ = 0;
  toggle_ = false;
  retries_left_ = cfg_.retries;
  last_request_ = request;
  tx_pending_ = false;
  deadline_ = now + cfg_.timeout;
  state_ = state;
}

bool SdoClient::on_frame(const can::Frame& f, TimePoint now) noexcept {
  if (f.is_extended() || f.is_rtr() || f.is_error() || f.id != response_cob_id()) return false;
  // CiA 301 SDO frames always carry 8 bytes; shorter ones cannot be parsed
  // safely (a segment's n and an initiate's size refer to all 8).
  if (state_ == State::kIdle || f.len != 8) return true;

  const auto scs = static_cast<uint8_t>(f.data[0] >> kCsShift);
  if (scs == kCsAbort) {
    // Accepted whatever object it names: a server may abort with a zero
    // multiplexer when it could not even parse our request, and giving up
    // on a stale abort is cheaper than hanging until the timeout.
    complete(sdo_abort_error(read_u32le(f.data, 4)), 0);
    return true;
  }
  switch (state_) {
    case State::kDownloadInitiate: on_download_initiate(f, now); break;
    case State::kDownloadSegment: on_download_segment(f, now); break;
    case State::kUploadInitiate: on_upload_initiate(f, now); break;
    case State::kUploadSegment: on_upload_segment(f, now); break;
    case State::kIdle: break;
  }
  return true;
}

void SdoClient::on_download_initiate(const can::Frame& f, TimePoint now) noexcept {
  if (stale_initiate_response(f, cfg_.accept_download_sub_mismatch)) return;
  if ((f.data[0] >> kCsShift) != kScsDownloadInitiate) {
    fail(SdoAbort::kCommandSpecifierInvalid);
    return;
  }
  if (last_segment_sent_) {  // expedited: the confirmation ends it
    complete({}, 0);
    return;
  }
  state_ = State::kDownloadSegment;
  toggle_ = false;  // the first segment has t = 0 (CiA 301 §7.2.4.3.4)
  send_download_segment(now);
}

void SdoClient::send_download_segment(TimePoint now) noexcept {
  segment_bytes_ = std::min(kSegmentMax, size_ - offset_);
  last_segment_sent_ = offset_ + segment_bytes_ == size_;
  const auto n = static_cast<uint8_t>(kSegmentMax - segment_bytes_);
  std::array<uint8_t, 8> d{};
  d[0] = static_cast<uint8_t>(command(kCcsDownloadSegment) | (toggle_ ? kBitToggle : 0) | (n << 1) |
                              (last_segment_sent_ ? kBitLastSegment : 0));
  std::copy_n(buffer_.get() + offset_, segment_bytes_, d.begin() + 1);
  send_request(can::Frame::make8(request_cob_id(), d), now);
}

void SdoClient::on_download_segment(const can::Frame& f, TimePoint now) noexcept {
  if ((f.data[0] >> kCsShift) != kScsDownloadSegment) {
    fail(SdoAbort::kCommandSpecifierInvalid);
    return;
  }
  if (((f.data[0] & kBitToggle) != 0) != toggle_) {
    fail(SdoAbort::kToggleBitNotAlternated);
    return;
  }
  offset_ += segment_bytes_;
  if (last_segment_sent_) {
    complete({}, 0);
    return;
  }
  toggle_ = !toggle_;
  send_download_segment(now);
}

void SdoClient::on_upload_initiate(const can::Frame& f, TimePoint now) noexcept {
  if (stale_initiate_response(f, false)) return;
  const uint8_t c = f.data[0];
  if ((c >> kCsShift) != kScsUploadInitiate) {
    fail(SdoAbort::kCommandSpecifierInvalid);
    return;
  }
  const bool expedited = (c & kBitExpedited) != 0;
  const bool sized = (c & kBitSizeIndicated) != 0;
  if (expedited) {
    // 0x43/0x47/0x4B/0x4F carry 4/3/2/1 bytes; 0x42 (size not indicated,
    // J§1.6.2, E§7.2) carries 4 and the caller knows the object's type.
    const std::size_t n = sized ? static_cast<std::size_t>((c >> 2) & 0x03u) : 0;
    const std::size_t len = kExpeditedMax - n;
    std::copy_n(f.data.begin() + 4, len, buffer_.get());
    complete({}, len);
    return;
  }
  size_indicated_ = sized;
  size_ = sized ? read_u32le(f.data, 4) : 0;
  if (sized && size_ > cfg_.buffer_size) {
    // CiA 301 has no "object too large for the client" code; out of memory
    // is what the client actually runs into.
    fail(SdoAbort::kOutOfMemory);
    return;
  }
  offset_ = 0;
  toggle_ = false;
  state_ = State::kUploadSegment;
  send_request(can::Frame::make8(request_cob_id(), {command(kCcsUploadSegment), 0, 0, 0, 0, 0, 0, 0}), now);
}

void SdoClient::on_upload_segment(const can::Frame& f, TimePoint now) noexcept {
  const uint8_t c = f.data[0];
  if ((c >> kCsShift) != kScsUploadSegment) {
    fail(SdoAbort::kCommandSpecifierInvalid);
    return;
  }
  if (((c & kBitToggle) != 0) != toggle_) {
    fail(SdoAbort::kToggleBitNotAlternated);
    return;
  }
  const std::size_t len = kSegmentMax - static_cast<std::size_t>((c >> 1) & 0x07u);
  const bool last = (c & kBitLastSegment) != 0;
  if (size_indicated_ && offset_ + len > size_) {
    fail(SdoAbort::kLengthTooHigh);
    return;
  }
  if (offset_ + len > cfg_.buffer_size) {  // only reachable without a size indication
    fail(SdoAbort::kOutOfMemory);
    return;
  }
  std::copy_n(f.data.begin() + 1, len, buffer_.get() + offset_);
  offset_ += len;
  if (last) {
    if (size_indicated_ && offset_ != size_) {
      fail(SdoAbort::kLengthTooLow);
      return;
    }
    complete({}, offset_);
    return;
  }
  toggle_ = !toggle_;
  send_request(can::Frame::make8(request_cob_id(),
                                 {static_cast<uint8_t>(command(kCcsUploadSegment) | (toggle_ ? kBitToggle : 0)),
                                  0, 0, 0, 0, 0, 0, 0}),
               now);
}

TimePoint SdoClient::process(TimePoint now) noexcept {
  if (state_ == State::kIdle) return kNever;
  if (tx_pending_ && now >= tx_retry_at_) {
    if (send(last_request_)) {
      tx_pending_ = false;
    } else {
      tx_retry_at_ = now + cfg_.tx_retry;
    }
  }
  if (now >= deadline_) {
    const bool initiating = state_ == State::kUploadInitiate || state_ == State::kDownloadInitiate;
    if (initiating && retries_left_ > 0) {
      --retries_left_;
      send_request(last_request_, now);
    } else {
      fail(SdoAbort::kProtocolTimedOut);
      return kNever;
    }
  }
  return tx_pending_ ? std::min(deadline_, tx_retry_at_) : deadline_;
}

void SdoClient::abort(SdoAbort code) noexcept {
  if (state_ == State::kIdle) return;
  fail(code);
}

void SdoClient::forget() noexcept {
  state_ = State::kIdle;
  tx_pending_ = false;
  deadline_ = kNever;
  result_.reset();
}

std::optional<SdoClient::Result> SdoClient::take_result() noexcept {
  std::optional<Result> r = result_;
  result_.reset();
  return r;
}

bool SdoClient::send(const can::Frame& frame) noexcept { return sink_.send(frame); }

bool SdoClient::send_request(const can::Frame& frame, TimePoint now) noexcept {
  last_request_ = frame;
  deadline_ = now + cfg_.timeout;
  const bool sent = send(frame);
  tx_pending_ = !sent;
  tx_retry_at_ = sent ? kNever : now + cfg_.tx_retry;
  return sent;
}

void SdoClient::send_abort(uint32_t code) noexcept {
  can::Frame f = multiplexed_frame(request_cob_id(), command(kCsAbort), index_, sub_);
  write_u32le(f.data, 4, code);
  // Best effort: if the frame cannot be queued the server's own SDO timeout
  // ends the transfer on its side.
  (void)send(f);
}

void SdoClient::fail(SdoAbort code) noexcept {
  send_abort(static_cast<uint32_t>(code));
  complete(make_error_code(code), 0);
}

void SdoClient::complete(std::error_code error, std::size_t upload_bytes) noexcept {
  const bool upload = state_ == State::kUploadInitiate || state_ == State::kUploadSegment;
  Result r;
  r.index = index_;
  r.sub = sub_;
  r.direction = upload ? Direction::kUpload : Direction::kDownload;
  r.error = error;
  if (!error && upload) r.data = std::span<const uint8_t>(buffer_.get(), upload_bytes);
  result_ = r;
  state_ = State::kIdle;
  tx_pending_ = false;
  deadline_ = kNever;
}

bool SdoClient::stale_initiate_response(const can::Frame& f, bool lenient_sub) const noexcept {
  // Only initiate responses carry a multiplexer; one naming another object is
  // checked before the command specifier so that a late upload answer cannot
  // end a download (and vice versa).
  const auto scs = static_cast<uint8_t>(f.data[0] >> kCsShift);
  if (scs != kScsUploadInitiate && scs != kScsDownloadInitiate) return false;
  const auto index = static_cast<uint16_t>(f.data[1] | (f.data[2] << 8));
  return index != index_ || (!lenient_sub && f.data[3] != sub_);
}

}  // namespace cobridge::canopen
