// ElectionBus: gateways' MasterElections on one simulated CAN bus, stepped
// in 1 ms ticks with a fake clock, for the election's unit tests
// (master_election_test.cpp) and its fuzz target (tests/fuzz/election_fuzz.cpp).
// Thread: test code, single-threaded.
#pragma once

#include <algorithm>
#include <initializer_list>
#include <memory>
#include <vector>

#include "can/frame.hpp"
#include "canopen/cob_id.hpp"
#include "canopen/master_election.hpp"

namespace cobridge::canopen::election_testing {

using namespace std::chrono_literals;
using can::Frame;

// Gateways on one bus, stepped in 1 ms ticks: a frame one sends reaches the
// others in the same tick, as on a CAN bus (a sender does not see its own).
class Bus {
 public:
  struct Gateway : can::FrameSink {
    explicit Gateway(MasterElectionConfig c) : election(c) {}
    bool send(const Frame& f) noexcept override {
      sent.push_back({f, now});
      pending.push_back(f);
      return true;
    }
    MasterElection election;
    struct Sent {
      Frame frame;
      TimePoint at;
    };
    std::vector<Sent> sent;
    std::vector<Frame> pending;
    std::vector<ElectionEvent> events;
    TimePoint now{};
    bool alive = true;
    // Until then its timers are not run (a process the host preempted, or
    // a guest's late wake-up): frames still reach it as they come.
    TimePoint timers_late_until{};
  };

  Gateway& add(uint8_t node, uint8_t priority = 0, bool preempt = false, Duration hold = 10s) {
    MasterElectionConfig c;
    c.node_id = node;
    c.priority = priority;
    c.preempt = preempt;
    c.hold = hold;
    gws_.push_back(std::make_unique<Gateway>(c));
    Gateway* g = gws_.back().get();
    g->election.set_callback([g](const ElectionEvent& e) { g->events.push_back(e); });
    g->election.set_excluded(excluded_);
    return *g;
  }
  // The node-IDs every gateway added from now on is told are devices'.
  void exclude(std::initializer_list<uint8_t> nodes) {
    for (uint8_t n : nodes) excluded_.set(n);
  }
  // A frame from a stranger (a raw CAN socket): every live gateway gets it now.
  void inject(const Frame& f) {
    for (auto& to : gws_) {
      if (!to->alive) continue;
      to->now = now_;
      (void)to->election.on_frame(f, now_, *to);
    }
    deliver();
  }
  // A device's heartbeat every `period` while the bus runs (0x700 + node, state).
  void device_heartbeat(uint8_t node, uint8_t state, Duration period = 100ms) {
    devices_.push_back({node, state, period, now_});
  }
  void start(Gateway& g) {
    g.now = now_;
    g.election.start(now_, g);
    deliver();
  }
  // Runs until `d` has passed; `each` is checked after every tick.
  template <typename Check>
  void run(Duration d, Check each) {
    const TimePoint end = now_ + d;
    while (now_ < end) {
      now_ += 1ms;
      for (auto& dev : devices_) {
        if (now_ - dev.last < dev.period) continue;
        dev.last = now_;
        inject(Frame::make(cob::kNmtErrorControlBase + dev.node, {dev.state}));
      }
      for (auto& g : gws_) {
        if (!g->alive || now_ < g->timers_late_until) continue;
        g->now = now_;
        (void)g->election.process(now_, *g);
      }
      deliver();
      each();
    }
  }
  void run(Duration d) {
    run(d, [] {});
  }
  [[nodiscard]] int masters() const {
    int n = 0;
    for (const auto& g : gws_) n += g->alive && g->election.is_master() ? 1 : 0;
    return n;
  }
  [[nodiscard]] TimePoint now() const { return now_; }

 private:
  void deliver() {
    for (bool more = true; more;) {
      more = false;
      for (auto& from : gws_) {
        std::vector<Frame> frames;
        frames.swap(from->pending);
        for (const Frame& f : frames) {
          more = true;
          for (auto& to : gws_) {
            if (to.get() == from.get() || !to->alive) continue;
            to->now = now_;
            (void)to->election.on_frame(f, now_, *to);
          }
        }
      }
    }
  }
  struct Device {
    uint8_t node;
    uint8_t state;
    Duration period;
    TimePoint last;
  };
  std::vector<std::unique_ptr<Gateway>> gws_;
  std::vector<Device> devices_;
  NodeSet excluded_;
  TimePoint now_ = TimePoint{} + 1h;
};

// The longest time the bus went without a master heartbeat (05h from any
// gateway) between `from` and `to`, from the frames the gateways sent.
inline Duration longest_without_master(const std::vector<const Bus::Gateway*>& gws, TimePoint from, TimePoint to) {
  std::vector<TimePoint> beats;
  for (const auto* g : gws) {
    for (const auto& s : g->sent) {
      const bool heartbeat = s.frame.id > cob::kNmtErrorControlBase && s.frame.id <= cob::kNmtErrorControlBase + 127;
      if (heartbeat && s.frame.data[0] == 0x05 && s.at >= from && s.at <= to) beats.push_back(s.at);
    }
  }
  std::sort(beats.begin(), beats.end());
  Duration worst{};
  TimePoint last = from;
  for (TimePoint t : beats) {
    worst = std::max(worst, t - last);
    last = t;
  }
  return std::max(worst, to - last);
}

}  // namespace cobridge::canopen::election_testing
