#include "canopen/sdo_observer.hpp"

#include <algorithm>

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
  if (on_block_request(t, frame, now)) return;
  t = Transfer{};
  const bool block = cs == sp::kCcsBlockDownload && (b0 & 0x01U) == 0;
  if (cs != sp::kCcsDownloadInitiate && !block) return;  // an upload, an abort: nothing written
  begin(t, node, frame, now);
  if (block) {
    t.phase = Phase::block_initiated;
  } else if ((b0 & sp::kBitExpedited) == 0) {
    t.phase = Phase::initiated;
  } else {
    const std::size_t unused = (b0 & sp::kBitSizeIndicated) != 0 ? (b0 >> 2U) & 0x03U : 0;
    keep(t.write, &frame.data[4], sp::kExpeditedMax - unused);
    t.phase = Phase::expedited;
  }
}

void SdoObserver::begin(Transfer& t, std::uint8_t node, const can::Frame& frame, TimePoint now) noexcept {
  t.at = now;
  t.write.node = node;
  t.write.index = sp::index_of(frame.data);
  t.write.sub = frame.data[3];
}

// A block download's segments and its end request; false: not one (the
// caller starts over). In a sub-block every client frame is a segment,
// byte 0 = c << 7 | seqno, whatever its bits would mean elsewhere.
bool SdoObserver::on_block_request(Transfer& t, const can::Frame& frame, TimePoint now) noexcept {
  const std::uint8_t b0 = frame.data[0];
  const auto seqno = static_cast<std::uint8_t>(b0 & 0x7FU);
  if (t.phase == Phase::block && seqno != 0) {  // seqno 0: 0x80, an abort
    // Out of order (one lost): the server takes none after it either, and
    // its block ack says so; ignored here too.
    if (t.last || seqno != t.seq + 1) return true;
    // Kept at its place in the transfer: a segment sent again after a
    // block ack overwrites what it overwrote the first time.
    t.write.total = t.acked + static_cast<std::uint32_t>(t.seq * sp::kSegmentMax);
    t.write.size = static_cast<std::uint8_t>(std::min<std::uint32_t>(t.write.total, SdoObserver::kKeptBytes));
    keep(t.write, &frame.data[1], sp::kSegmentMax);
    t.seq = seqno;
    t.last = (b0 & 0x80U) != 0;
    if (t.last) t.last_seq = seqno;
    t.at = now;
    return true;
  }
  if (t.phase == Phase::block_end && b0 == (sp::command(sp::kCcsBlockDownload) | 0x01U | (b0 & 0x1CU))) {
    const std::uint32_t unused = (b0 >> 2U) & 0x07U;  // n: bytes of the last segment that hold no data
    t.write.total -= std::min(unused, t.write.total);
    t.write.size = static_cast<std::uint8_t>(std::min<std::uint32_t>(t.write.size, t.write.total));
    t.at = now;
    return true;
  }
  return false;
}

std::optional<ObservedWrite> SdoObserver::on_response(Transfer& t, const can::Frame& frame, TimePoint now) noexcept {
  if (t.phase == Phase::idle) return std::nullopt;
  if (now - t.at > kAnswerWithin) {
    t = Transfer{};
    return std::nullopt;
  }
  const std::uint8_t cs = sp::specifier(frame.data[0]);
  if (cs == sp::kScsBlockDownload) return on_block_response(t, frame);
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

// The server's side of a block download: its initiate response opens the
// first sub-block, a block ack ends one (ackseq: the segments it took), the
// end response confirms the write.
std::optional<ObservedWrite> SdoObserver::on_block_response(Transfer& t, const can::Frame& frame) noexcept {
  const std::uint8_t ss = frame.data[0] & 0x03U;
  const bool same = sp::index_of(frame.data) == t.write.index && frame.data[3] == t.write.sub;
  if (ss == 0 && t.phase == Phase::block_initiated && same) {
    t.phase = Phase::block;
    return std::nullopt;
  }
  if (ss == 2 && t.phase == Phase::block) {
    const std::uint8_t ackseq = std::min(frame.data[1], t.seq);
    t.acked += static_cast<std::uint32_t>(ackseq * sp::kSegmentMax);
    t.write.total = t.acked;
    t.write.size = static_cast<std::uint8_t>(std::min<std::uint32_t>(t.write.total, SdoObserver::kKeptBytes));
    const bool all = t.last && ackseq == t.last_seq;
    t.seq = 0;
    t.last = false;
    if (all) t.phase = Phase::block_end;
    return std::nullopt;
  }
  if (ss == 1 && t.phase == Phase::block_end) {
    const ObservedWrite w = t.write;
    t = Transfer{};
    return w;
  }
  t = Transfer{};
  return std::nullopt;
}

}  // namespace cobridge::canopen
