// can::VirtualBus: an in-process CAN bus for unit tests of the layers above.
//
// Every attached Port is a BusPort (a FrameSink with receive, events and
// counters), so a bus's controller runs on it as on a socket. A frame sent on one port is queued at
// every other port, as on a real bus where a node does not receive its own
// telegrams (SocketCAN's default, CAN_RAW_RECV_OWN_MSGS off). The bus keeps a
// log of everything sent so tests can assert the exact frames on the wire.
// Thread: single-threaded; the test thread owns the bus and all its ports.
// Allocates on send (queues grow): test use only, never in the daemon.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <vector>

#include "can/bus_port.hpp"
#include "can/frame.hpp"

namespace cobridge::can {

class VirtualBus {
 public:
  class Port final : public BusPort {
   public:
    Port(const Port&) = delete;
    Port& operator=(const Port&) = delete;

    // Broadcasts to the other ports. Returns false only while the port is
    // set to refuse sending (to test the callers' back-pressure handling).
    [[nodiscard]] bool send(const Frame& frame) noexcept override;

    // Takes the oldest frame queued at this port; false when none.
    [[nodiscard]] bool receive(Frame& out) noexcept;

    // BusPort. Frames queued while the port is closed are kept; a closed
    // port hands none out and sends none (a test's interface down).
    [[nodiscard]] bool is_open() const noexcept override { return open_; }
    [[nodiscard]] std::size_t receive(std::span<Frame> out) noexcept override;
    TimePoint process(TimePoint /*now*/) override { return TimePoint::max(); }
    [[nodiscard]] std::span<const BusEvent> take_events() noexcept override;
    [[nodiscard]] ChannelStats stats() const noexcept override { return stats_; }
    [[nodiscard]] int fd() const noexcept override { return -1; }
    void close() noexcept override { open_ = false; }

    // A test's bus events: queued for the next take_events(). Closing or
    // opening the port queues InterfaceDown / InterfaceReopened, as the
    // socket does when its interface goes and comes back.
    void add_event(const BusEvent& event);
    void set_open(bool open);

    [[nodiscard]] std::size_t pending() const noexcept { return queue_.size(); }
    // Sends refused while blocked or closed (the stats' tx_dropped), and frames
    // lost because this port was full.
    [[nodiscard]] uint64_t tx_refused() const noexcept { return stats_.tx_dropped; }
    [[nodiscard]] uint64_t rx_dropped() const noexcept { return rx_dropped_; }

    void set_send_blocked(bool blocked) noexcept { send_blocked_ = blocked; }
    void clear() noexcept { queue_.clear(); }

   private:
    friend class VirtualBus;
    Port(VirtualBus& bus, std::size_t capacity) : bus_(&bus), capacity_(capacity) {}
    void deliver(const Frame& frame);

    VirtualBus* bus_;
    std::size_t capacity_;
    std::deque<Frame> queue_;
    std::vector<BusEvent> events_;
    std::vector<BusEvent> taken_;
    ChannelStats stats_;
    bool open_ = true;
    bool send_blocked_ = false;
    uint64_t rx_dropped_ = 0;
  };

  static constexpr std::size_t kUnbounded = static_cast<std::size_t>(-1);

  VirtualBus() = default;
  VirtualBus(const VirtualBus&) = delete;
  VirtualBus& operator=(const VirtualBus&) = delete;

  // The reference stays valid for the bus's lifetime. A port with a bounded
  // capacity drops (and counts) frames arriving while it is full, like a
  // socket whose receive buffer overflowed.
  Port& attach(std::size_t capacity = kUnbounded);

  [[nodiscard]] std::size_t port_count() const noexcept { return ports_.size(); }
  // Frames sent from now on carry this time (ns, as a kernel's receive
  // stamp; a test's fake clock); unset: they keep the sender's.
  void stamp_with(std::function<int64_t()> now_ns) { stamp_ = std::move(now_ns); }

  // Every frame sent on the bus, in order.
  [[nodiscard]] const std::vector<Frame>& log() const noexcept { return log_; }
  void clear_log() noexcept { log_.clear(); }

 private:
  void broadcast(const Port& from, const Frame& frame);

  std::vector<std::unique_ptr<Port>> ports_;
  std::vector<Frame> log_;
  std::function<int64_t()> stamp_;
};

}  // namespace cobridge::can
