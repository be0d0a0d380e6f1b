#include "app/bus_fault.hpp"

#include <linux/can/error.h>

namespace cobridge::sim {

std::optional<BusErrorKind> parse_bus_error_kind(std::string_view text) noexcept {
  for (const BusErrorKind k : {BusErrorKind::error_warning, BusErrorKind::error_passive, BusErrorKind::error_active,
                               BusErrorKind::bus_off, BusErrorKind::restarted})
    if (text == to_string(k)) return k;
  return std::nullopt;
}

std::string_view to_string(BusErrorKind kind) noexcept {
  switch (kind) {
    case BusErrorKind::error_warning: return "error-warning";
    case BusErrorKind::error_passive: return "error-passive";
    case BusErrorKind::error_active: return "error-active";
    case BusErrorKind::bus_off: return "bus-off";
    case BusErrorKind::restarted: return "restarted";
  }
  return "?";
}

can::Frame make_error_frame(BusErrorKind kind) noexcept {
  // Layout of <linux/can/error.h>: class bits in the identifier, controller
  // status in data[1], error counters in data[6] (tx) and data[7] (rx) when
  // CAN_ERR_CNT is set; always CAN_ERR_DLC bytes.
  can::Frame f;
  f.flags = can::Frame::kFlagError;
  f.len = CAN_ERR_DLC;
  switch (kind) {
    case BusErrorKind::error_warning:
      f.id = CAN_ERR_CRTL | CAN_ERR_CNT;
      f.data[1] = CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING;
      f.data[6] = 96;
      f.data[7] = 96;
      break;
    case BusErrorKind::error_passive:
      f.id = CAN_ERR_CRTL | CAN_ERR_CNT;
      f.data[1] = CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE;
      f.data[6] = 128;
      f.data[7] = 128;
      break;
    case BusErrorKind::error_active:
      f.id = CAN_ERR_CRTL | CAN_ERR_CNT;
      f.data[1] = CAN_ERR_CRTL_ACTIVE;
      break;
    case BusErrorKind::bus_off:
      f.id = CAN_ERR_BUSOFF;
      break;
    case BusErrorKind::restarted:
      f.id = CAN_ERR_RESTARTED;
      break;
  }
  return f;
}

void TrafficGenerator::start_flood(canopen::TimePoint now, canopen::Duration duration) noexcept {
  flood_ = true;
  cob_id_ = kFloodId;
  until_ = now + duration;
}

void TrafficGenerator::start_babble(std::uint32_t cob_id, canopen::TimePoint now,
                                    canopen::Duration duration) noexcept {
  flood_ = false;
  cob_id_ = cob_id;
  until_ = now + duration;
}

std::size_t TrafficGenerator::burst(canopen::TimePoint now, std::span<can::Frame> out) noexcept {
  if (!active(now)) return 0;
  for (can::Frame& f : out) {
    f = can::Frame{};
    f.id = cob_id_;
    if (cob_id_ > 0x7FF) f.flags = can::Frame::kFlagExtended;
    if (!flood_) {
      // A babbling node repeats its telegram with changing content.
      f.len = 8;
      for (std::size_t i = 0; i < 8; ++i) f.data[i] = static_cast<std::uint8_t>(counter_ >> (8 * i));
      ++counter_;
    }
  }
  generated_ += out.size();
  return out.size();
}

}  // namespace cobridge::sim
