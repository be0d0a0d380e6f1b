// SdoObserver: the SDO downloads another client makes on the bus, seen from
// the side: a service tool on its own CAN adapter that writes an object
// the gateway's configuration sets (its drift is then noticed like a write
// through the gateway; docs/operations.md "Configuration differs").
//
// It follows a client's download to a server from the request (0x600+n)
// to the server's confirmation (0x580+n), CiA 301 §7.2.4.3.3..§7.2.4.3.6:
//   expedited:  initiate (ccs 1, e = 1, the value in bytes 4..7)
//               -> confirmed by the initiate response (scs 3, same index:sub);
//   segmented:  initiate (ccs 1, e = 0) -> initiate response (scs 3), then
//               segments (ccs 0) -> confirmed by the response (scs 1) to the
//               segment with c = 1; the first kKeptBytes bytes are kept.
//   block (§7.2.4.3.9..§7.2.4.3.14): initiate (ccs 6, cs 0) -> initiate
//               response (scs 5, ss 0), then sub-blocks of segments (seqno
//               1..127, c = 1 on the last), each acknowledged (scs 5, ss 2,
//               ackseq: the segments after it are sent again), then end
//               (ccs 6, cs 1, n unused bytes in the last segment) ->
//               confirmed by the end response (scs 5, ss 1). The CRC is the
//               server's to check: its confirmation says it held.
// An abort (cs 4) either way, another request, or a confirmation later than
// kAnswerWithin forgets the transfer. Block uploads write nothing.
//
// Which requests are another client's is the caller's knowledge: the bus
// manager's socket never receives its own frames (SocketCAN loops a frame
// back to the other sockets only, CAN_RAW_RECV_OWN_MSGS being off).
//
// Thread: the bus's control thread; no allocation.
#pragma once

#include "can/frame.hpp"
#include "canopen/clock.hpp"

#include <array>
#include <chrono>
#include <cstdint>
#include <optional>

namespace cobridge::canopen {

struct ObservedWrite {
  std::uint8_t node = 0;
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::array<std::uint8_t, 8> data{};  // the first `size` bytes written (at most kKeptBytes)
  std::uint8_t size = 0;
  std::uint32_t total = 0;  // the bytes the client wrote in all
};

class SdoObserver {
 public:
  static constexpr std::size_t kKeptBytes = 8;
  static constexpr std::chrono::milliseconds kAnswerWithin{1000};

  // A frame the caller's socket received: the write it confirms, if any.
  [[nodiscard]] std::optional<ObservedWrite> on_frame(const can::Frame& frame, TimePoint now) noexcept;

 private:
  enum class Phase : std::uint8_t { idle, expedited, initiated, segments, block_initiated, block, block_end };
  struct Transfer {
    Phase phase = Phase::idle;
    bool last = false;        // the client sent the segment with c = 1
    std::uint8_t seq = 0;     // block: the last segment's seqno in this sub-block
    std::uint8_t last_seq = 0;  // block: the seqno of the segment with c = 1
    std::uint32_t acked = 0;  // block: the bytes of the sub-blocks acknowledged
    TimePoint at{};           // the latest request
    ObservedWrite write;
  };
  void on_request(Transfer& t, std::uint8_t node, const can::Frame& frame, TimePoint now) noexcept;
  [[nodiscard]] bool on_block_request(Transfer& t, const can::Frame& frame, TimePoint now) noexcept;
  void begin(Transfer& t, std::uint8_t node, const can::Frame& frame, TimePoint now) noexcept;
  [[nodiscard]] std::optional<ObservedWrite> on_response(Transfer& t, const can::Frame& frame,
                                                         TimePoint now) noexcept;
  [[nodiscard]] std::optional<ObservedWrite> on_block_response(Transfer& t, const can::Frame& frame) noexcept;
  std::array<Transfer, 128> transfers_{};
};

}  // namespace cobridge::canopen
