// can::BusPort: one CAN bus as a bus's control thread uses it: frames in
// (batches, with the receive time) and out, open or not, the bus events its
// error frames and the link tell, and its counters.
//
// Two of them: SocketCanChannel (the daemon, a Linux CAN_RAW socket) and
// VirtualBus::Port (unit tests: the bus controller's decisions run on an
// in-process bus with simulated devices and a fake clock, no kernel).
// Thread: one thread owns a port and makes every call except stats(),
// which any thread may read.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>

#include "can/bus_event.hpp"
#include "can/frame.hpp"
#include "can/frame_sink.hpp"

namespace cobridge::can {

struct ChannelStats {
  uint64_t rx_frames = 0;          // data frames handed out by receive()
  uint64_t tx_frames = 0;          // frames the kernel accepted
  uint64_t tx_dropped = 0;         // send() returned false
  uint64_t rx_overflow_drops = 0;  // frames the kernel dropped at our socket (SO_RXQ_OVFL)
  uint64_t error_frames = 0;       // error frames received and decoded
  uint64_t events_dropped = 0;     // bus events lost because nobody took them
  uint64_t reopens = 0;            // successful reopens after the interface went down
};

class BusPort : public FrameSink {
 public:
  using Clock = std::chrono::steady_clock;
  using TimePoint = Clock::time_point;

  [[nodiscard]] virtual bool is_open() const noexcept = 0;
  // Reads up to out.size() data frames without blocking; 0 when nothing is
  // left (or the port is closed). Bus events go to take_events().
  [[nodiscard]] virtual std::size_t receive(std::span<Frame> out) noexcept = 0;
  // Upkeep at `now` (a closed port reopens with backoff); returns when it
  // wants to be called again.
  virtual TimePoint process(TimePoint now) = 0;
  // The bus events since the last call; valid until the next call.
  [[nodiscard]] virtual std::span<const BusEvent> take_events() noexcept = 0;
  [[nodiscard]] virtual ChannelStats stats() const noexcept = 0;
  // A descriptor to poll for frames; -1 when there is none (closed, or an
  // in-process bus whose frames a test hands over itself).
  [[nodiscard]] virtual int fd() const noexcept = 0;
  virtual void close() noexcept = 0;
};

}  // namespace cobridge::can
