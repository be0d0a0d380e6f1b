// BusController without its shell (bus_controller.hpp): the test is the
// shell. It hands the controller the frames of a virtual bus and a clock
// reading of its own choosing, four years away from the host's clock: what
// the controller stamps comes from that reading alone, what it sends goes
// through the port it was given, and its timeline events go to the
// TimelineSink it was given. The decisions themselves are
// bus_manager_test.cpp's (the same controller under its real shell, stepped).
#include <gtest/gtest.h>

#include <array>
#include <string>

#include "bus/bus_controller.hpp"
#include "unit/bus/virtual_line.hpp"

namespace cobridge::bus::test {
namespace {

class RecordingSink final : public TimelineSink {
 public:
  void note(const std::string& device, const TimelineEvent& e) override {
    noted.emplace_back(device, e);
    pending_ = true;
  }
  [[nodiscard]] bool pending() const noexcept override { return pending_; }
  void hand_over(TimelineJournal::Devices devices) override {
    handed_over.push_back(devices.size());
    pending_ = false;
  }
  std::vector<std::pair<std::string, TimelineEvent>> noted;
  std::vector<std::size_t> handed_over;  // the number of timelines, per hand-over

 private:
  bool pending_ = false;
};

// One turn as the daemon's shell takes it (bus_manager.cpp), by hand: its
// clock reading, the frames, the components, new work at once, settle.
TimePoint turn(BusController& ctl, can::VirtualBus::Port& port, FakeBusClock& clock) {
  const TimePoint now = clock.now();
  ctl.set_time(now, clock.wall());
  std::array<can::Frame, 16> frames{};
  bool lost = false;
  for (std::size_t n = frames.size(); n == frames.size();) {
    n = port.receive(frames);
    for (std::size_t i = 0; i < n; ++i) ctl.on_frame(frames[i], now, now);
    lost = ctl.on_port_events(now) || lost;
  }
  TimePoint next = ctl.process(now, lost);
  while (ctl.handle_outputs(now)) next = ctl.run_components(now);
  return std::min(next, ctl.settle(now));
}

std::optional<DeviceStatus> published(const BusController& ctl, const std::string& name) {
  const std::lock_guard lock(ctl.mutex);
  for (const auto& d : ctl.published.devices)
    if (d.name == name) return d;
  return std::nullopt;
}

const char* const kMultiturnAt20 =
    "[[device]]\nname = \"mt-a\"\nbus = \"line1\"\nmodel = \"MC1-2800\"\nserial = 2001\nnode_id = 20\n"
    "heartbeat_ms = 100\n[device.tpdo1]\nmapping = [\"position\"]\ntransmission = \"event\"\nevent_timer_ms = 100\n";

// CiA 301 §7.2.8.2.1.1 (pre-operational to operational after the
// configuration by SDO, CiA 301 §7.2.4) on the shell's time: a multiturn
// (E, the MC1's manual §6) configured and started, every stamp from the
// readings the test gave, none from the host's clock.
TEST(BusController, Cia301_ConfiguresOnTheShellsClockReadingAlone) {
  VirtualLine line("bitrate = 250\ndiscovery_period_s = 30\n", kMultiturnAt20);
  (void)line.add_device("MC1-2800", 2001, 20);
  line.clock().step_wall(std::chrono::seconds(4LL * 365 * 24 * 3600));
  line.power_on();
  const WallTime from = line.clock().wall();
  ASSERT_GT(from - std::chrono::system_clock::now(), std::chrono::hours(24 * 365 * 3));

  RecordingSink sink;
  BusManagerOptions o;
  BusController ctl(line.config(), 0, line.catalog(), line.store(), o, &sink, {}, line.now(), from);
  can::VirtualBus::Port& port = line.port();
  port.set_open(true);
  (void)port.take_events();
  ctl.attach(port);
  ctl.set_time(line.now(), from);
  ctl.opened(line.now());
  ctl.start_components(line.now());

  // One step of the line: the devices, then the controller's turn when it
  // is due or frames wait for it; time moves as VirtualLine's own steps.
  TimePoint due = line.now();
  const auto step = [&] {
    bool moved = false;
    const TimePoint next = line.step_devices(moved);
    if (line.now() >= due || port.pending() > 0) {
      due = turn(ctl, port, line.clock());
      moved = true;
    }
    line.move_time(port.pending() > 0, moved, std::min(next, due));
  };
  const TimePoint limit = line.now() + 5s;
  while (line.now() < limit) {
    step();
    const auto d = published(ctl, "mt-a");
    if (d && d->state == DeviceState::operational) break;
  }
  const WallTime to = line.clock().wall();
  const auto d = published(ctl, "mt-a");
  ASSERT_TRUE(d.has_value());
  ASSERT_EQ(d->state, DeviceState::operational) << d->last_error;
  EXPECT_GE(d->since, from);
  EXPECT_LE(d->since, to);

  ASSERT_FALSE(sink.noted.empty());
  EXPECT_EQ(sink.noted.front().second.text, "gateway started");
  for (const auto& [device, e] : sink.noted) {
    EXPECT_EQ(device, "mt-a");
    EXPECT_GE(e.at, from) << e.text;
    EXPECT_LE(e.at, to) << e.text;
  }

  // TPDO1 (0x180 + 20) flows, and the controller's own frames went out
  // through the port it was given: NMT start of node 20 (CiA 301 §7.2.8.3.1.1).
  const TimePoint until = line.now() + 1s;
  while (line.now() < until) step();
  const auto& log = line.bus().log();
  EXPECT_TRUE(std::any_of(log.begin(), log.end(), [](const can::Frame& f) {
    return f.id == 0 && f.len == 2 && f.data[0] == 0x01 && f.data[1] == 20;
  }));
  EXPECT_GT(std::count_if(log.begin(), log.end(), [](const can::Frame& f) { return f.id == 0x180U + 20; }), 3);

  // At the stop the journal gets every configured device's timeline.
  ctl.finish_run(line.now());
  ASSERT_FALSE(sink.handed_over.empty());
  EXPECT_EQ(sink.handed_over.back(), 1U);
}

}  // namespace
}  // namespace cobridge::bus::test
