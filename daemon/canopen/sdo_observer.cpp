#include "canopen/sdo_observer.hpp"

#include "canopen/cob_id.hpp"
#include "canopen/sdo_protocol.hpp"

namespace cobridge::canopen {

namespace sp = sdo_protocol;

namespace {

void keep(ObservedWrite& w, const std::uint8_t* bytes, std::size_t n) noexcept {
  for (std::size_t i = 0; i < n; ++i) {
    if (w.size < w.data.size()) w.data[w.size++] = bytes[i];
  }
  w.total += static_cast<std::uint32_t>(n);
}

}  // namespace

std::optional<ObservedWrite> SdoObserver::on_frame(const can::Frame& frame, TimePoint now) noexcept {
  if (frame.is_rtr() || frame.is_extended() || frame.is_error() || frame.len != 8) return std::nullopt;
  if (frame.id > cob::kSdoRxBase && frame.id <= cob::kSdoRxBase + 127) {
    const auto node = static_cast<std::uint8_t>(frame.id - cob::kSdoRxBase);
    on_request(transfers_[node], node, frame, now);
    return std::nullopt;
  }
  if (frame.id > cob::kSdoTxBase && frame.id <= cob::kSdoTxBase + 127)
    return on_response(transfers_[frame.id - cob::kSdoTxBase], frame, now);
  return std::nullopt;
}

void SdoObserver::on_request(Transfer& t, std::uint8_t node, const can::Frame& frame, TimePoint now) noexcept {
  const std::uint8_t b0 = frame.data[0];
  const std::uint8_t cs = sp::specifier(b0);
  if (cs == sp::kCcsDownloadSegment && t.phase == Phase::segments && !t.last) {
    const std::size_t unused = (b0 >> 1U) & 0x07U;  // n: bytes 7-n+1..7 hold no data
    keep(t.write, &frame.data[1], sp::kSegmentMax - unused);
    t.last = (b0 & sp::kBitLastSegment) != 0;
    t.at = now;
    return;
  }
  t = Transfer{};
  if (cs != sp::kCcsDownloadInitiate) return;  // an upload, an abort: nothing written
  t.at = now;
  t.write.node = node;
  t.write.index = sp::index_of(frame.data);
  t.write.sub = frame.data[3];
  if ((b0 & sp::kBitExpedited) == 0) {
    t.phase = Phase::initiated;
    return;
  }
  const std::size_t unused = (b0 & sp::kBitSizeIndicated) != 0 ? (b0 >> 2U) & 0x03U : 0;
  keep(t.write, &frame.data[4], sp::kExpeditedMax - unused);
  t.phase = Phase::expedited;
}

std::optional<ObservedWrite> SdoObserver::on_response(Transfer& t, const can::Frame& frame, TimePoint now) noexcept {
  if (t.phase == Phase::idle) return std::nullopt;
  if (now - t.at > kAnswerWithin) {
    t = Transfer{};
    return std::nullopt;
  }
  const std::uint8_t cs = sp::specifier(frame.data[0]);
  const bool same = sp::index_of(frame.data) == t.write.index && frame.data[3] == t.write.sub;
  if (cs == sp::kScsDownloadInitiate && same && t.phase == Phase::initiated) {
    t.phase = Phase::segments;
    return std::nullopt;
  }
  const bool done = (cs == sp::kScsDownloadInitiate && same && t.phase == Phase::expedited) ||
                    (cs == sp::kScsDownloadSegment && t.phase == Phase::segments && t.last);
  if (done) {
    const ObservedWrite w = t.write;
    t = Transfer{};
    return w;
  }
  if (cs == sp::kCsAbort) t = Transfer{};
  return std::nullopt;
}

}  // namespace cobridge::canopen
