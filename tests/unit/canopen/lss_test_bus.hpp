// Test-only LSS bus: one LssMaster, N LssSlaves and a fake clock.
//
// A master frame reaches every slave at the time it is sent; slave answers
// reach the master after `answer_latency`, one after the other `answer_gap`
// apart (arbitration serialises simultaneous answers), so several answers to
// one request arrive as separate frames inside the same timeout window. The
// bus logs every frame with its time so tests can check the wire byte for byte
// and measure what an operation cost in frames and fake time.
// Thread: single-threaded test code; allocates freely.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <ostream>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "can/frame_sink.hpp"
#include "canopen/clock.hpp"
#include "canopen/lss_master.hpp"
#include "canopen/lss_slave.hpp"

namespace cobridge::canopen::test {

using namespace std::chrono_literals;

// Keeps what a component sends; refuses while `refuse` is set.
class RecordingSink final : public can::FrameSink {
 public:
  [[nodiscard]] bool send(const can::Frame& f) noexcept override {
    if (refuse) return false;
    frames.push_back(f);
    return true;
  }
  std::vector<can::Frame> frames;
  bool refuse = false;
};

class LssTestBus {
 public:
  struct Entry {
    TimePoint at;
    can::Frame frame;
  };

  explicit LssTestBus(LssMasterConfig config = LssMasterConfig{}, Duration answer_latency = 1ms,
                      Duration answer_gap = 250us)
      : master_port_(*this), master_(master_port_, config), latency_(answer_latency), gap_(answer_gap) {}

  LssSlave& add_slave(const LssAddress& identity, uint8_t node_id,
                      LssSlave::Features features = LssSlave::Features{}) {
    auto node = std::make_unique<Node>(*this, latency_);
    node->slave = std::make_unique<LssSlave>(node->port, identity, node_id, features);
    nodes_.push_back(std::move(node));
    return *nodes_.back()->slave;
  }
  // Makes one slave answer later than the others (e.g. later than the timeout).
  void set_slave_latency(std::size_t i, Duration latency) { nodes_.at(i)->port.latency = latency; }
  // Makes one answer of one slave late: its k-th answer from now (0 = the next).
  void delay_answer(std::size_t i, std::size_t k, Duration latency) {
    auto& port = nodes_.at(i)->port;
    port.late_at = port.answers + k;
    port.late_latency = latency;
  }

  LssMaster& master() { return master_; }
  LssSlave& slave(std::size_t i) { return *nodes_.at(i)->slave; }
  [[nodiscard]] std::size_t slave_count() const { return nodes_.size(); }
  [[nodiscard]] TimePoint now() const { return now_; }
  const std::vector<Entry>& log() const { return log_; }
  void clear_log() { log_.clear(); }
  void set_master_send_blocked(bool blocked) { master_port_.blocked = blocked; }

  // Runs until the master is idle and nothing is in flight.
  void run() { run_until(kNever); }

  // Like run(), but stops before anything that would happen after `limit`.
  void run_until(TimePoint limit) {
    for (int guard = 0; guard < 10'000'000; ++guard) {
      const TimePoint deadline = master_.process(now_);
      const TimePoint next = events_.empty() ? kNever : events_.begin()->first;
      if (deadline == kNever && next == kNever) return;
      if (std::min(deadline, next) > limit) return;
      if (next <= deadline) {
        if (next > now_) now_ = next;
        const Event e = events_.begin()->second;
        events_.erase(events_.begin());
        dispatch(e);
      } else {
        now_ = deadline;
      }
    }
    ADD_FAILURE() << "LssTestBus::run did not settle";
  }

  // Runs and returns the master's result (empty if none).
  std::optional<LssMaster::Result> run_result() {
    run();
    return master_.take_result();
  }

  // Frames in the log sent by the master (0x7E5) / the slaves (0x7E4).
  [[nodiscard]] std::size_t count(uint32_t cob_id) const {
    std::size_t n = 0;
    for (const auto& e : log_) n += e.frame.id == cob_id ? 1u : 0u;
    return n;
  }

 private:
  struct Event {
    can::Frame frame;
    bool from_master;
  };

  class MasterPort final : public can::FrameSink {
   public:
    explicit MasterPort(LssTestBus& bus) : bus_(bus) {}
    [[nodiscard]] bool send(const can::Frame& f) noexcept override {
      if (blocked) return false;
      bus_.events_.emplace(bus_.now_, Event{f, true});
      return true;
    }
    bool blocked = false;

   private:
    LssTestBus& bus_;
  };

  class SlavePort final : public can::FrameSink {
   public:
    SlavePort(LssTestBus& bus, Duration l) : latency(l), bus_(bus) {}
    [[nodiscard]] bool send(const can::Frame& f) noexcept override {
      TimePoint at = bus_.now_ + (answers++ == late_at ? late_latency : latency);
      if (at < bus_.last_answer_ + bus_.gap_) at = bus_.last_answer_ + bus_.gap_;
      bus_.last_answer_ = at;
      bus_.events_.emplace(at, Event{f, false});
      return true;
    }
    Duration latency;
    std::size_t answers = 0;
    std::size_t late_at = SIZE_MAX;  // the answer (by count) sent `late_latency` after its request
    Duration late_latency{};

   private:
    LssTestBus& bus_;
  };

  struct Node {
    Node(LssTestBus& bus, Duration latency) : port(bus, latency) {}
    SlavePort port;
    std::unique_ptr<LssSlave> slave;
  };

  void dispatch(const Event& e) {
    log_.push_back(Entry{now_, e.frame});
    if (e.from_master) {
      for (auto& n : nodes_) n->slave->on_frame(e.frame);
    } else {
      master_.on_frame(e.frame, now_);
    }
  }

  MasterPort master_port_;
  LssMaster master_;
  Duration latency_;
  Duration gap_;
  std::vector<std::unique_ptr<Node>> nodes_;
  std::multimap<TimePoint, Event> events_;  // equal times keep send order
  std::vector<Entry> log_;
  TimePoint now_ = TimePoint{} + 1h;
  TimePoint last_answer_{};
};

// The 8 data bytes of a frame, for byte-for-byte comparisons.
inline can::Frame lss_tx(std::array<uint8_t, 8> bytes) { return can::Frame::make8(0x7E5, bytes); }
inline can::Frame lss_rx(std::array<uint8_t, 8> bytes) { return can::Frame::make8(0x7E4, bytes); }

}  // namespace cobridge::canopen::test

namespace cobridge::can {
// Readable frames in GoogleTest failure messages.
inline void PrintTo(const Frame& f, std::ostream* os) {
  char buf[64];
  int n = std::snprintf(buf, sizeof buf, "%03X [%u]", static_cast<unsigned>(f.id), static_cast<unsigned>(f.len));
  for (uint8_t i = 0; i < f.len && i < 8; ++i)
    n += std::snprintf(buf + n, sizeof buf - static_cast<std::size_t>(n), " %02X", static_cast<unsigned>(f.data[i]));
  *os << buf;
}
}  // namespace cobridge::can
