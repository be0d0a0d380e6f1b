#include "can/bus_event.hpp"

#include <linux/can.h>
#include <linux/can/error.h>

namespace cobridge::can {
namespace {

class EventWriter {
 public:
  EventWriter(std::span<BusEvent> out, const Frame& frame) noexcept : out_(out) {
    proto_.timestamp_ns = frame.timestamp_ns;
    if ((frame.id & CAN_ERR_CNT) != 0) {
      proto_.has_counters = true;
      proto_.tx_error_count = frame.data[6];
      proto_.rx_error_count = frame.data[7];
    }
  }

  void add(BusEventKind kind, uint8_t info = 0, uint8_t location = 0) noexcept {
    if (n_ >= out_.size()) return;
    BusEvent e = proto_;
    e.kind = kind;
    e.info = info;
    e.location = location;
    out_[n_++] = e;
  }

  [[nodiscard]] std::size_t count() const noexcept { return n_; }

 private:
  std::span<BusEvent> out_;
  BusEvent proto_{};
  std::size_t n_ = 0;
};

}  // namespace

std::size_t decode_error_frame(const Frame& frame, std::span<BusEvent> out) noexcept {
  if (!frame.is_error()) return 0;
  const uint32_t cls = frame.id;
  EventWriter w(out, frame);

  // Bus state first: a consumer that only looks at the first event of a
  // frame still sees the most severe news.
  if ((cls & CAN_ERR_BUSOFF) != 0) w.add(BusEventKind::BusOff);
  if ((cls & CAN_ERR_RESTARTED) != 0) w.add(BusEventKind::Restarted);
  if ((cls & CAN_ERR_CRTL) != 0) {
    const uint8_t st = frame.data[1];
    constexpr uint8_t kPassive = CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE;
    constexpr uint8_t kWarning = CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING;
    bool known = false;
    if ((st & kPassive) != 0) {
      w.add(BusEventKind::ErrorPassive, st);
      known = true;
    }
    if ((st & kWarning) != 0) {
      w.add(BusEventKind::ErrorWarning, st);
      known = true;
    }
    if ((st & CAN_ERR_CRTL_ACTIVE) != 0) {
      w.add(BusEventKind::ErrorActive, st);
      known = true;
    }
    if ((st & CAN_ERR_CRTL_RX_OVERFLOW) != 0) {
      w.add(BusEventKind::ControllerRxOverflow, st);
      known = true;
    }
    if ((st & CAN_ERR_CRTL_TX_OVERFLOW) != 0) {
      w.add(BusEventKind::ControllerTxOverflow, st);
      known = true;
    }
    if (!known) w.add(BusEventKind::ControllerProblem, st);
  }
  if ((cls & CAN_ERR_PROT) != 0) w.add(BusEventKind::ProtocolViolation, frame.data[2], frame.data[3]);
  if ((cls & CAN_ERR_TRX) != 0) w.add(BusEventKind::Transceiver, frame.data[4]);
  if ((cls & CAN_ERR_ACK) != 0) w.add(BusEventKind::AckMissing);
  if ((cls & CAN_ERR_LOSTARB) != 0) w.add(BusEventKind::LostArbitration, frame.data[0]);
  if ((cls & CAN_ERR_TX_TIMEOUT) != 0) w.add(BusEventKind::TxTimeout);
  if ((cls & CAN_ERR_BUSERROR) != 0) w.add(BusEventKind::BusError);
  return w.count();
}

std::string_view to_string(BusEventKind kind) noexcept {
  switch (kind) {
    case BusEventKind::ErrorWarning: return "error-warning";
    case BusEventKind::ErrorPassive: return "error-passive";
    case BusEventKind::ErrorActive: return "error-active";
    case BusEventKind::BusOff: return "bus-off";
    case BusEventKind::Restarted: return "restarted";
    case BusEventKind::ControllerRxOverflow: return "controller-rx-overflow";
    case BusEventKind::ControllerTxOverflow: return "controller-tx-overflow";
    case BusEventKind::ProtocolViolation: return "protocol-violation";
    case BusEventKind::Transceiver: return "transceiver";
    case BusEventKind::AckMissing: return "ack-missing";
    case BusEventKind::LostArbitration: return "lost-arbitration";
    case BusEventKind::TxTimeout: return "tx-timeout";
    case BusEventKind::BusError: return "bus-error";
    case BusEventKind::ControllerProblem: return "controller-problem";
    case BusEventKind::InterfaceDown: return "interface-down";
    case BusEventKind::InterfaceReopened: return "interface-reopened";
  }
  return "unknown";
}

}  // namespace cobridge::can
