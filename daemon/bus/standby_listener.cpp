// StandbyListener: see standby_listener.hpp.
#include "bus/standby_listener.hpp"

#include <utility>

#include "canopen/cob_id.hpp"
#include "canopen/nmt.hpp"

namespace cobridge::bus {
namespace {

using canopen::cob::kNmtErrorControlBase;
using canopen::cob::kSdoRxBase;
using canopen::cob::kSdoTxBase;

constexpr std::uint16_t kIdentityObject = 0x1018;

// The frame's node when its COB-ID is `base` + 1..127, else 0.
std::uint8_t node_of(const can::Frame& f, std::uint32_t base) noexcept {
  return f.id > base && f.id <= base + 127 ? static_cast<std::uint8_t>(f.id - base) : 0;
}

std::uint16_t index_of(const can::Frame& f) noexcept {
  return static_cast<std::uint16_t>(f.data[1] | f.data[2] << 8);
}

bool identity_sub(std::uint16_t index, std::uint8_t sub) noexcept {
  return index == kIdentityObject && sub >= 1 && sub <= 4;
}

std::uint32_t le32(const std::uint8_t* p) noexcept {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

}  // namespace

StandbyListener::Heard StandbyListener::hear(const can::Frame& frame, canopen::TimePoint now,
                                             std::chrono::milliseconds sdo_timeout) noexcept {
  if (frame.is_extended() || frame.is_rtr()) return {};
  if (node_of(frame, kNmtErrorControlBase) != 0) return heartbeat(frame);
  if (node_of(frame, kSdoTxBase) != 0) return answer(frame, now, sdo_timeout);
  if (node_of(frame, kSdoRxBase) != 0) request(frame, now);
  return {};
}

// A heartbeat (or boot-up) is one byte: the NMT state, bit 7 the guarding
// toggle (CiA 301 7.2.8.3.2).
StandbyListener::Heard StandbyListener::heartbeat(const can::Frame& frame) const noexcept {
  if (frame.len != 1) return {};
  Heard h{Heard::Kind::state, node_of(frame, kNmtErrorControlBase)};
  h.operational = (frame.data[0] & 0x7F) == static_cast<std::uint8_t>(canopen::NmtState::operational);
  return h;
}

// An upload initiate request (CiA 301 7.2.4.3.2: ccs 2, byte 0 = 0x40) of
// 0x1018 sub 1..4 is remembered; an upload of any other object forgets it.
void StandbyListener::request(const can::Frame& frame, canopen::TimePoint now) noexcept {
  if (frame.len != 8 || frame.data[0] != 0x40) return;
  const std::uint8_t node = node_of(frame, kSdoRxBase);
  asked_[node] = identity_sub(index_of(frame), frame.data[3]) ? Asked{frame.data[3], now} : Asked{};
}

// An expedited upload response (CiA 301 7.2.4.3.3: scs 2, e = 1) carries
// the value in bytes 4..7.
StandbyListener::Heard StandbyListener::answer(const can::Frame& frame, canopen::TimePoint now,
                                               std::chrono::milliseconds sdo_timeout) noexcept {
  if (frame.len != 8 || (frame.data[0] & 0xE2) != 0x42) return {};
  const std::uint8_t sub = frame.data[3];
  if (!identity_sub(index_of(frame), sub)) return {};
  const std::uint8_t node = node_of(frame, kSdoTxBase);
  const Asked asked = std::exchange(asked_[node], Asked{});
  if (asked.sub != sub || now - asked.at > sdo_timeout) return {};  // nobody asked
  canopen::LssAddress& id = identity_[node];
  const std::uint32_t v = le32(&frame.data[4]);
  (sub == 1 ? id.vendor : sub == 2 ? id.product : sub == 3 ? id.revision : id.serial) = v;
  if (sub != 4) return {};
  Heard h{Heard::Kind::identity, node};
  h.identity = id;
  return h;
}

}  // namespace cobridge::bus
