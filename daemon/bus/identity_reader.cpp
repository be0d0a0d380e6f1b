#include "bus/identity_reader.hpp"

namespace cobridge::bus {

namespace {
constexpr std::uint16_t kIdentity = 0x1018;
constexpr std::uint8_t kLastSub = 4;
constexpr std::uint32_t kSdoTimeout = 0x05040000;  // CiA 301 §7.2.4.3.17: SDO protocol timed out
}  // namespace

IdentityReader::~IdentityReader() {
  if (running_) sdo_.forget();
}

Error IdentityReader::start(canopen::TimePoint now) {
  if (sdo_.busy())
    return Error(Errc::kUnavailable, "the SDO client is busy", {},
                 std::make_error_code(std::errc::device_or_resource_busy));
  (void)sdo_.take_result();
  sub_ = 0;
  read_ = {};
  identity_.reset();
  error_.clear();
  done_ = false;
  running_ = true;
  next(now);
  return {};
}

void IdentityReader::next(canopen::TimePoint now) {
  ++sub_;
  if (sub_ > kLastSub) {
    running_ = false;
    done_ = true;
    identity_ = read_;
    return;
  }
  if (const std::error_code ec = sdo_.start_upload(kIdentity, sub_, now)) {
    running_ = false;
    done_ = true;
    error_ = ec;
  }
}

bool IdentityReader::on_frame(const can::Frame& frame, canopen::TimePoint now) noexcept {
  if (!running_) return false;
  const bool mine = sdo_.on_frame(frame, now);
  if (mine) collect(now);
  return mine;
}

canopen::TimePoint IdentityReader::process(canopen::TimePoint now) noexcept {
  if (!running_) return canopen::kNever;
  (void)sdo_.process(now);
  collect(now);
  return running_ ? sdo_.process(now) : canopen::kNever;
}

void IdentityReader::collect(canopen::TimePoint now) {
  const auto r = sdo_.take_result();
  if (!r) return;
  if (!r->ok()) {
    if (sub_ == kLastSub && r->error.value() != static_cast<int>(kSdoTimeout)) {
      // 0x1018/4 is optional (CiA 301): a device that refuses it still has an identity.
      running_ = false;
      done_ = true;
      identity_ = read_;
      return;
    }
    running_ = false;
    done_ = true;
    error_ = r->error;
    return;
  }
  const std::uint32_t v = r->as_u32();
  switch (sub_) {
    case 1: read_.vendor = v; break;
    case 2: read_.product = v; break;
    case 3: read_.revision = v; break;
    default: read_.serial = v; break;
  }
  next(now);
}

}  // namespace cobridge::bus
