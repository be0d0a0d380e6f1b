// can::BusEvent: something that happened to the CAN bus or to the interface,
// as opposed to a telegram on it.
//
// Linux reports controller and bus problems as error frames (CAN_ERR_FLAG set,
// class bits in the identifier, details in the data bytes, see
// <linux/can/error.h> and the kernel's SocketCAN documentation, "Network
// Problem Notifications"). `decode_error_frame` turns one such frame into the
// events it carries; the SocketCAN channel adds the interface events it
// observes itself (interface down, interface reopened).
// Thread-safety: plain values and pure functions; no shared state.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <type_traits>

#include "can/frame.hpp"

namespace cobridge::can {

// The values are our own: one Linux error frame mixes class bits (identifier)
// and controller status bits (data[1]) that overlap numerically, so no single
// wire code exists. The wire bits are kept in BusEvent::info instead.
enum class BusEventKind : uint8_t {
  ErrorWarning = 1,          // a CAN error counter reached 96 (CAN_ERR_CRTL_{RX,TX}_WARNING)
  ErrorPassive,              // a counter reached 128 (CAN_ERR_CRTL_{RX,TX}_PASSIVE)
  ErrorActive,               // back to error-active (CAN_ERR_CRTL_ACTIVE)
  BusOff,                    // transmit error counter passed 255 (CAN_ERR_BUSOFF)
  Restarted,                 // controller restarted after bus-off (CAN_ERR_RESTARTED)
  ControllerRxOverflow,      // controller receive buffer overflow (CAN_ERR_CRTL_RX_OVERFLOW)
  ControllerTxOverflow,      // controller transmit buffer overflow (CAN_ERR_CRTL_TX_OVERFLOW)
  ProtocolViolation,         // bit/stuff/form/CRC error (CAN_ERR_PROT)
  Transceiver,               // wiring fault reported by the transceiver (CAN_ERR_TRX)
  AckMissing,                // nobody acknowledged our frame (CAN_ERR_ACK)
  LostArbitration,           // CAN_ERR_LOSTARB
  TxTimeout,                 // the driver gave up transmitting (CAN_ERR_TX_TIMEOUT)
  BusError,                  // unspecified bus error (CAN_ERR_BUSERROR)
  ControllerProblem,         // CAN_ERR_CRTL with no status bit we know
  InterfaceDown,             // the network interface went down or vanished
  InterfaceReopened,         // the channel is open again and frames can flow
};

struct BusEvent {
  BusEventKind kind = BusEventKind::BusError;
  // Kind-specific wire byte: controller status data[1] for the controller
  // kinds, protocol error type data[2] for ProtocolViolation, transceiver
  // status data[4] for Transceiver, bit position data[0] for LostArbitration.
  uint8_t info = 0;
  // Protocol violations only: location data[3] (CAN_ERR_PROT_LOC_*).
  uint8_t location = 0;
  // Error counters from data[6]/data[7], valid when has_counters (CAN_ERR_CNT).
  bool has_counters = false;
  uint8_t tx_error_count = 0;
  uint8_t rx_error_count = 0;
  uint8_t reserved[2] = {0, 0};
  int64_t timestamp_ns = 0;  // kernel time of the error frame, CLOCK_REALTIME

  friend constexpr bool operator==(const BusEvent&, const BusEvent&) noexcept = default;
};

static_assert(std::is_trivially_copyable_v<BusEvent>);
static_assert(sizeof(BusEvent) == 16);

// Upper bound on the events one error frame can carry (every class bit and
// every controller status bit set).
inline constexpr std::size_t kMaxEventsPerErrorFrame = 16;

// Decodes a Linux CAN error frame (`frame.is_error()`, class bits in
// `frame.id`) into `out`, in a fixed order (bus state first, then details).
// Returns the number of events written; events beyond out.size() are left
// out. A non-error frame yields 0. Allocation-free, for the receive path.
[[nodiscard]] std::size_t decode_error_frame(const Frame& frame, std::span<BusEvent> out) noexcept;

[[nodiscard]] std::string_view to_string(BusEventKind kind) noexcept;

}  // namespace cobridge::can
