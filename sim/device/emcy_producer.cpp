#include "device/emcy_producer.hpp"

#include <chrono>

namespace cobridge::sim {

namespace {

constexpr std::uint16_t kCobIdEmcy = 0x1014;
constexpr std::uint16_t kInhibitEmcy = 0x1015;
constexpr std::uint16_t kErrorRegister = 0x1001;
constexpr std::uint16_t kErrorField = 0x1003;
constexpr std::uint16_t kEmcyBehaviour = 0x2104;  // multiturn only (E§4.3)
constexpr std::uint8_t kHistoryDepth = 10;

bool suppressed(std::uint8_t filter, families::EmcyLevel level) noexcept {
  using families::EmcyLevel;
  switch (level) {
    case EmcyLevel::info: return filter >= 1;
    case EmcyLevel::warn: return filter >= 2;
    case EmcyLevel::error: return filter >= 3;
    case EmcyLevel::hard:
    case EmcyLevel::unspecified: return false;
  }
  return false;
}

}  // namespace

void EmcyProducer::attach(canopen::ObjectDictionary* od, SendFn send_fn, void* context) noexcept {
  od_ = od;
  send_ = send_fn;
  context_ = context;
  reset();
}

void EmcyProducer::reset() noexcept {
  queued_ = 0;
  have_sent_ = false;
}

void EmcyProducer::set_error_register(std::uint8_t bits) noexcept {
  register_ = bits;
  if (od_ != nullptr) (void)od_->set_u8(kErrorRegister, 0, bits);
}

bool EmcyProducer::send(const canopen::Emcy& emcy, families::EmcyLevel level, TimePoint now) noexcept {
  if (od_ == nullptr) return false;
  if (od_->contains(kEmcyBehaviour, 0) && suppressed(od_->get_u8(kEmcyBehaviour, 0).value_or(0), level))
    return false;
  if (od_->contains(kInhibitEmcy, 0)) {
    const auto inhibit = std::chrono::microseconds(100) * od_->get_u16(kInhibitEmcy, 0).value_or(0);
    if (queued_ > 0 || (have_sent_ && now < last_sent_ + inhibit)) {
      if (queued_ == kQueue) return false;
      queue_[queued_++] = emcy;
      return true;
    }
  }
  return transmit(emcy, now);
}

TimePoint EmcyProducer::process(TimePoint now) noexcept {
  if (queued_ == 0 || od_ == nullptr) return canopen::kNever;
  const auto inhibit = std::chrono::microseconds(100) * od_->get_u16(kInhibitEmcy, 0).value_or(0);
  if (now < last_sent_ + inhibit) return last_sent_ + inhibit;
  const canopen::Emcy head = queue_[0];
  for (std::size_t i = 1; i < queued_; ++i) queue_[i - 1] = queue_[i];
  --queued_;
  transmit(head, now);
  return queued_ > 0 ? now + inhibit : canopen::kNever;
}

bool EmcyProducer::transmit(const canopen::Emcy& emcy, TimePoint now) noexcept {
  const std::uint32_t cob = od_->get_u32(kCobIdEmcy, 0).value_or(0x80000000u);
  record_history(emcy);
  if ((cob & 0x80000000u) != 0 || send_ == nullptr) return false;
  have_sent_ = true;
  last_sent_ = now;
  return send_(context_, canopen::make_emcy_on(cob & 0x7FFu, emcy));
}

void EmcyProducer::record_history(const canopen::Emcy& emcy) noexcept {
  if (!od_->contains(kErrorField, 1) || emcy.error_code == 0) return;
  // CiA 301 §7.5.2.4: bits 0-15 the code, 16-31 manufacturer information.
  const std::uint32_t entry = emcy.error_code | (std::uint32_t{emcy.manufacturer[0]} << 16) |
                              (std::uint32_t{emcy.manufacturer[1]} << 24);
  for (std::uint8_t sub = kHistoryDepth; sub > 1; --sub) {
    if (!od_->contains(kErrorField, sub)) continue;
    (void)od_->set_u32(kErrorField, sub, od_->get_u32(kErrorField, static_cast<std::uint8_t>(sub - 1)).value_or(0));
  }
  (void)od_->set_u32(kErrorField, 1, entry);
  const std::uint8_t count = od_->get_u8(kErrorField, 0).value_or(0);
  if (count < kHistoryDepth) (void)od_->set_u8(kErrorField, 0, static_cast<std::uint8_t>(count + 1));
}

}  // namespace cobridge::sim
