// VirtualLine: one bus's controller (BusManager in stepped use, no thread)
// on a can::VirtualBus with the simulator's own encoders (sim::SimDevice)
// and a fake clock. The controller's decisions (commissioning, plans,
// supervision, drift, election) then run in unit tests in milliseconds of
// CPU, with no kernel, no sleep and no timing that depends on the host.
//
// Time moves by itself: while frames are on their way it steps by the
// time a frame takes on the wire; when the bus is quiet it jumps to the
// next deadline of the controller or of a device.
// Thread: the test's one thread owns everything here.
#pragma once

#include <gtest/gtest.h>
#include <spdlog/sinks/ringbuffer_sink.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "bus/bus_clock.hpp"
#include "bus/bus_manager.hpp"
#include "bus/state_store.hpp"
#include "can/virtual_bus.hpp"
#include "config/load.hpp"
#include "device/device_catalog.hpp"
#include "device/eds.hpp"
#include "device/sim_device.hpp"
#include "sys/logging.hpp"
#include "unit/device/source_paths.hpp"

namespace cobridge::bus::test {

using namespace std::chrono_literals;
using canopen::TimePoint;

class FakeBusClock final : public BusClock {
 public:
  TimePoint now() const noexcept override { return now_; }
  WallTime wall() const noexcept override {
    return WallTime{std::chrono::seconds{1'800'000'000}} + step_ +
           std::chrono::duration_cast<WallTime::duration>(now_ - TimePoint{});
  }
  void set(TimePoint t) noexcept { now_ = t; }
  // The wall clock stepped (NTP), the steady one not.
  void step_wall(std::chrono::seconds by) noexcept { step_ += by; }

 private:
  TimePoint now_{std::chrono::seconds{1000}};
  std::chrono::seconds step_{0};
};

// Adds a capturing sink to the loggers of the layers a bus goes through,
// and takes it away again: what a bus logged, for the assertions.
class LogCapture {
 public:
  LogCapture() {
    for (const char* m : kModules) sys::logger(m)->sinks().push_back(sink_);
  }
  ~LogCapture() {
    for (const char* m : kModules) std::erase(sys::logger(m)->sinks(), sink_);
  }
  LogCapture(const LogCapture&) = delete;
  LogCapture& operator=(const LogCapture&) = delete;
  [[nodiscard]] std::vector<std::string> lines() const { return sink_->last_formatted(); }
  [[nodiscard]] std::size_t count(const std::string& part) const {
    const auto all = lines();
    return static_cast<std::size_t>(
        std::count_if(all.begin(), all.end(), [&](const std::string& l) { return l.find(part) != std::string::npos; }));
  }

 private:
  static constexpr const char* kModules[] = {"can", "canopen", "gateway"};
  std::shared_ptr<spdlog::sinks::ringbuffer_sink_mt> sink_ = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(1024);
};

// What the observer was told, for the assertions.
class RecordingObserver final : public BusObserver {
 public:
  void on_device_configured(const DeviceStatus& d, const std::vector<std::uint32_t>& tpdo1,
                            const std::vector<std::uint32_t>&) override {
    configured.push_back({d.name, tpdo1});
  }
  void on_device_status(const DeviceStatus& d) override { states.push_back({d.name, d.state}); }
  struct Configured {
    std::string device;
    std::vector<std::uint32_t> tpdo1;
  };
  std::vector<Configured> configured;
  std::vector<std::pair<std::string, DeviceState>> states;
};

class VirtualLine {
 public:
  // About a frame's time on the wire at 250 kbit/s (8 data bytes, stuffing).
  static constexpr auto kFrameTime = 500us;

  // `bus_toml`: the [[bus]] table's keys; `devices_toml`: [[device]] tables;
  // one gateway per entry of `gateways`, each the rest of its own
  // configuration (a [redundancy] table for a hot-standby pair).
  // `gateway_port_capacity`: frames a gateway's port holds before it drops
  // them (a socket's receive queue; counted as its SO_RXQ_OVFL).
  VirtualLine(const std::string& bus_toml, const std::string& devices_toml,
              const std::vector<std::string>& gateways = {""},
              std::size_t gateway_port_capacity = can::VirtualBus::kUnbounded)
      : dir_(std::filesystem::temp_directory_path() /
             ("cobridge-vline-" + std::to_string(::getpid()) + "-" + std::to_string(++instances_))) {
    std::filesystem::remove_all(dir_);
    bus_.stamp_with([this] {
      return std::chrono::duration_cast<std::chrono::nanoseconds>(clock_.wall().time_since_epoch()).count();
    });
    for (const auto& extra : gateways) {
      auto g = std::make_unique<Gateway>(bus_.attach(gateway_port_capacity));
      g->dir = dir_ / ("gateway-" + std::to_string(gateways_.size()));
      std::filesystem::create_directories(g->dir);
      g->extra = extra;
      g->config = load(*g, bus_toml, devices_toml);
      g->store = std::make_unique<StateStore>(g->dir);
      EXPECT_FALSE(g->store->load());
      gateways_.push_back(std::move(g));
    }
    for (const auto& e : catalog_.load_directory(device::test::shipped_devices_dir())) ADD_FAILURE() << e.to_string();
  }
  ~VirtualLine() {
    for (auto& g : gateways_) g->manager.reset();
    std::filesystem::remove_all(dir_);
  }
  VirtualLine(const VirtualLine&) = delete;
  VirtualLine& operator=(const VirtualLine&) = delete;

  // Gateway `g`'s configuration with `bus_toml` and `devices_toml`, as the
  // daemon loads it (for a reload).
  config::Config load(const std::string& bus_toml, const std::string& devices_toml, std::size_t g = 0) const {
    return load(*gateways_.at(g), bus_toml, devices_toml);
  }

  // A simulated encoder of `model` (cobridge-sim's model table); node 0:
  // the model's factory node-ID, 0xFF: non-configured (CiA 305).
  sim::SimDevice& add_device(const char* model, std::uint32_t serial, std::uint8_t node = 0) {
    sim::DeviceSpec spec;
    spec.model = sim::find_model(model);
    EXPECT_NE(spec.model, nullptr) << model;
    spec.serial = serial;
    spec.node_id = node;
    auto& port = bus_.attach();
    const device::DeviceDescription& eds = description_of(*spec.model);
    devices_.push_back({&port, std::make_unique<sim::SimDevice>(spec, eds, port, dir_ / "sim")});
    return *devices_.back().device;
  }

  // Devices on, then every gateway's controller opened.
  void start() {
    power_on();
    for (std::size_t i = 0; i < gateways_.size(); ++i) start_gateway(i);
  }
  void power_on() {
    for (auto& d : devices_) EXPECT_FALSE(d.device->power_on(clock_.now()));
  }
  // Gateway `g` (again, after stop_gateway): a new controller on its port.
  void start_gateway(std::size_t g) {
    Gateway& gw = *gateways_.at(g);
    BusManagerOptions o;
    o.observer = &gw.observer;
    o.port = &gw.port;
    o.clock = &clock_;
    o.ready_timeout = 10s;
    gw.port.set_open(true);
    (void)gw.port.take_events();
    gw.manager = std::make_unique<BusManager>(gw.config, 0, catalog_, *gw.store, o);
    ASSERT_FALSE(gw.manager->open());
    gw.next = clock_.now();
  }
  // Gateway `g` gone at once (a kill, a power cut): it says nothing more.
  void stop_gateway(std::size_t g) {
    Gateway& gw = *gateways_.at(g);
    gw.port.set_open(false);
    gw.manager.reset();
  }

  // Runs until `done(status)` holds, at most `limit` of bus time; returns
  // the bus time it took, nullopt when it never held.
  std::optional<std::chrono::milliseconds> run_until(const std::function<bool(const BusStatus&)>& done,
                                                     std::chrono::milliseconds limit) {
    const TimePoint from = clock_.now();
    while (clock_.now() - from <= limit) {
      step();
      if (done(status(running_gateway())))
        return std::chrono::duration_cast<std::chrono::milliseconds>(clock_.now() - from);
    }
    return std::nullopt;
  }
  void run_for(std::chrono::milliseconds d) {
    (void)run_until([](const BusStatus&) { return false; }, d);
  }

  // The first gateway that runs (run_until's status).
  [[nodiscard]] std::size_t running_gateway() const {
    for (std::size_t g = 0; g < gateways_.size(); ++g)
      if (gateways_[g]->manager) return g;
    return 0;
  }
  // A stopped gateway's status is empty.
  [[nodiscard]] BusStatus status(std::size_t g = 0) const {
    const Gateway& gw = *gateways_.at(g);
    return gw.manager ? gw.manager->status() : BusStatus{};
  }
  [[nodiscard]] std::optional<DeviceStatus> device(const std::string& name, std::size_t g = 0) const {
    for (const auto& d : status(g).devices)
      if (d.name == name) return d;
    return std::nullopt;
  }
  [[nodiscard]] TimePoint now() const { return clock_.now(); }
  // Gateway g's thread reads its clock now and is preempted for `lag` before
  // it reads its socket (a loaded host): no turn of it meanwhile, then one
  // on the clock it read, with what came in the meantime waiting.
  void stall(std::size_t g, canopen::Duration lag) {
    Gateway& gw = *gateways_.at(g);
    gw.clock_read = clock_.now();
    gw.stalled_until = clock_.now() + lag;
  }
  void step_wall_clock(std::chrono::seconds by) { clock_.step_wall(by); }
  [[nodiscard]] BusManager& manager(std::size_t g = 0) { return *gateways_.at(g)->manager; }
  [[nodiscard]] can::VirtualBus& bus() { return bus_; }
  // Every frame on the bus with the time it was there (the tap's).
  [[nodiscard]] const std::vector<std::pair<TimePoint, can::Frame>>& heard() const { return heard_; }
  [[nodiscard]] StateStore& store(std::size_t g = 0) { return *gateways_.at(g)->store; }
  [[nodiscard]] RecordingObserver& observer(std::size_t g = 0) { return gateways_.at(g)->observer; }

  static std::function<bool(const BusStatus&)> all_in(DeviceState s) {
    return [s](const BusStatus& st) {
      for (const auto& d : st.devices)
        if (d.state != s) return false;
      return !st.devices.empty();
    };
  }
  static std::function<bool(const BusStatus&)> is(const std::string& name, DeviceState s) {
    return [name, s](const BusStatus& st) {
      for (const auto& d : st.devices)
        if (d.name == name) return d.state == s;
      return false;
    };
  }

 private:
  struct Gateway {
    explicit Gateway(can::VirtualBus::Port& p) : port(p) {}
    can::VirtualBus::Port& port;
    std::filesystem::path dir;
    std::string extra;
    config::Config config;
    std::unique_ptr<StateStore> store;
    RecordingObserver observer;
    std::unique_ptr<BusManager> manager;  // null while stopped
    TimePoint next{};
    // stall(): the clock its thread read, and when the thread runs again.
    std::optional<TimePoint> clock_read;
    TimePoint stalled_until{};
  };

  config::Config load(const Gateway& g, const std::string& bus_toml, const std::string& devices_toml) const {
    const std::string text = "[gateway]\nid = \"unit\"\nstate_dir = \"" + g.dir.string() +
                             "\"\n\n[[bus]]\nname = \"line1\"\ninterface = \"vline0\"\n" + bus_toml + "\n" +
                             devices_toml + "\n" + g.extra;
    auto loaded = config::load_string(text, "virtual_line.toml", g.dir);
    for (const auto& d : loaded.diagnostics()) ADD_FAILURE() << config::to_string(d);
    return loaded.ok() ? std::move(loaded).config() : config::Config{};
  }

  struct Encoder {
    can::VirtualBus::Port* port;
    std::unique_ptr<sim::SimDevice> device;
  };

  const device::DeviceDescription& description_of(const sim::ModelInfo& m) {
    std::string file = std::string(m.eds_stem);
    if (m.family == families::FamilyId::novotechnik_rotary) file += "-1ch";
    auto r = device::load_eds_file(device::test::shipped_devices_dir() / (file + ".eds"));
    EXPECT_TRUE(r.ok()) << file;
    descriptions_.push_back(std::make_unique<device::DeviceDescription>(*r.description));
    return *descriptions_.back();
  }

  // One step: the devices take what reached them, then the controller
  // takes its turn; time moves one frame when frames are under way, else
  // to the earliest deadline.
  void step() {
    bool moved = false;
    TimePoint next = step_devices(moved);
    bool pending = false;
    for (auto& g : gateways_) {
      if (!g->manager) continue;
      if (clock_.now() < g->stalled_until) {
        next = std::min(next, g->stalled_until);
        continue;
      }
      if (g->clock_read || clock_.now() >= g->next || g->port.pending() > 0) {
        g->next = g->manager->turn(std::exchange(g->clock_read, std::nullopt).value_or(clock_.now()));
        moved = true;
      }
      next = std::min(next, g->next);
      pending = pending || g->port.pending() > 0;
    }
    move_time(pending, moved, next);
  }

 public:
  // The devices' part of a step (and the tap's): they take what reached
  // them and run; `moved` set when one took a frame; returns their next
  // deadline. For a test that drives a controller of its own.
  TimePoint step_devices(bool& moved) {
    can::Frame heard;
    while (tap_.receive(heard)) heard_.push_back({clock_.now(), heard});
    TimePoint next = canopen::kNever;
    for (auto& d : devices_) {
      can::Frame f;
      while (d.port->receive(f)) {
        d.device->on_frame(f, clock_.now());
        moved = true;
      }
      next = std::min(next, d.device->process(clock_.now()));
    }
    return next;
  }
  // Time moves one frame when frames are under way (`pending` at a
  // controller, or at a device) or something moved, else to `next`.
  void move_time(bool pending, bool moved, TimePoint next) {
    for (const auto& d : devices_) pending = pending || d.port->pending() > 0;
    const TimePoint t = clock_.now();
    clock_.set(pending || moved ? t + kFrameTime : std::max(next, t + kFrameTime));
  }
  [[nodiscard]] const config::Config& config(std::size_t g = 0) const { return gateways_.at(g)->config; }
  [[nodiscard]] can::VirtualBus::Port& port(std::size_t g = 0) { return gateways_.at(g)->port; }
  [[nodiscard]] const device::DeviceCatalog& catalog() const { return catalog_; }
  [[nodiscard]] FakeBusClock& clock() { return clock_; }

 private:

  static inline int instances_ = 0;
  std::filesystem::path dir_;
  device::DeviceCatalog catalog_;
  FakeBusClock clock_;
  can::VirtualBus bus_;
  // A listener of its own, as candump beside the gateways: what was on the
  // bus and when, independent of what any gateway says.
  can::VirtualBus::Port& tap_ = bus_.attach();
  std::vector<std::pair<TimePoint, can::Frame>> heard_;
  std::vector<std::unique_ptr<Gateway>> gateways_;
  std::vector<std::unique_ptr<device::DeviceDescription>> descriptions_;
  std::vector<Encoder> devices_;
};

}  // namespace cobridge::bus::test
