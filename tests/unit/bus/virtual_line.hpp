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

#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bus/bus_clock.hpp"
#include "bus/bus_manager.hpp"
#include "bus/state_store.hpp"
#include "can/virtual_bus.hpp"
#include "config/load.hpp"
#include "device/device_catalog.hpp"
#include "device/eds.hpp"
#include "device/sim_device.hpp"
#include "unit/device/source_paths.hpp"

namespace cobridge::gateway::test {

using namespace std::chrono_literals;
using canopen::TimePoint;

class FakeBusClock final : public BusClock {
 public:
  TimePoint now() const noexcept override { return now_; }
  WallTime wall() const noexcept override {
    return WallTime{std::chrono::seconds{1'800'000'000}} +
           std::chrono::duration_cast<WallTime::duration>(now_ - TimePoint{});
  }
  void set(TimePoint t) noexcept { now_ = t; }

 private:
  TimePoint now_{std::chrono::seconds{1000}};
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

  // `bus_toml`: the [[bus]] table's keys; `devices_toml`: [[device]] tables.
  VirtualLine(const std::string& bus_toml, const std::string& devices_toml)
      : dir_(std::filesystem::temp_directory_path() /
             ("cobridge-vline-" + std::to_string(::getpid()) + "-" + std::to_string(++instances_))) {
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    config_ = load(bus_toml, devices_toml);
    for (const auto& e : catalog_.load_directory(device::test::shipped_devices_dir())) ADD_FAILURE() << e.to_string();
    store_ = std::make_unique<StateStore>(dir_);
    EXPECT_FALSE(store_->load());
  }
  ~VirtualLine() {
    manager_.reset();
    std::filesystem::remove_all(dir_);
  }
  VirtualLine(const VirtualLine&) = delete;
  VirtualLine& operator=(const VirtualLine&) = delete;

  // The configuration of `bus_toml` and `devices_toml`, as the daemon loads it.
  config::Config load(const std::string& bus_toml, const std::string& devices_toml) const {
    const std::string text = "[gateway]\nid = \"unit\"\nstate_dir = \"" + dir_.string() +
                             "\"\n\n[[bus]]\nname = \"line1\"\ninterface = \"vline0\"\n" + bus_toml + "\n" +
                             devices_toml;
    auto loaded = config::load_string(text, "virtual_line.toml", dir_);
    for (const auto& d : loaded.diagnostics()) ADD_FAILURE() << config::to_string(d);
    return loaded.ok() ? std::move(loaded).config() : config::Config{};
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

  // Devices on, then the controller's port opened.
  void start() {
    for (auto& d : devices_) EXPECT_FALSE(d.device->power_on(clock_.now()));
    BusManagerOptions o;
    o.observer = &observer;
    o.port = &gateway_;
    o.clock = &clock_;
    o.ready_timeout = 10s;
    manager_ = std::make_unique<BusManager>(config_, 0, catalog_, *store_, o);
    ASSERT_FALSE(manager_->open());
    next_ = clock_.now();
  }

  // Runs until `done(status)` holds, at most `limit` of bus time; returns
  // the bus time it took, nullopt when it never held.
  std::optional<std::chrono::milliseconds> run_until(const std::function<bool(const BusStatus&)>& done,
                                                     std::chrono::milliseconds limit) {
    const TimePoint from = clock_.now();
    while (clock_.now() - from <= limit) {
      step();
      if (done(manager_->status()))
        return std::chrono::duration_cast<std::chrono::milliseconds>(clock_.now() - from);
    }
    return std::nullopt;
  }
  void run_for(std::chrono::milliseconds d) {
    (void)run_until([](const BusStatus&) { return false; }, d);
  }

  [[nodiscard]] BusStatus status() const { return manager_->status(); }
  [[nodiscard]] std::optional<DeviceStatus> device(const std::string& name) const {
    for (const auto& d : status().devices)
      if (d.name == name) return d;
    return std::nullopt;
  }
  [[nodiscard]] TimePoint now() const { return clock_.now(); }
  [[nodiscard]] BusManager& manager() { return *manager_; }
  [[nodiscard]] can::VirtualBus& bus() { return bus_; }
  [[nodiscard]] StateStore& store() { return *store_; }

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

  RecordingObserver observer;

 private:
  struct Encoder {
    can::VirtualBus::Port* port;
    std::unique_ptr<sim::SimDevice> device;
  };

  const device::DeviceDescription& description_of(const sim::ModelInfo& m) {
    std::string file = std::string(m.eds_stem);
    if (m.family == device::families::FamilyId::novotechnik_rotary) file += "-1ch";
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
    TimePoint next = next_;
    for (auto& d : devices_) {
      can::Frame f;
      while (d.port->receive(f)) {
        d.device->on_frame(f, clock_.now());
        moved = true;
      }
      next = std::min(next, d.device->process(clock_.now()));
    }
    if (clock_.now() >= next_ || gateway_.pending() > 0) {
      next_ = manager_->turn(clock_.now());
      moved = true;
    }
    next = std::min(next, next_);
    bool pending = gateway_.pending() > 0;
    for (const auto& d : devices_) pending = pending || d.port->pending() > 0;
    const TimePoint t = clock_.now();
    clock_.set(pending || moved ? t + kFrameTime : std::max(next, t + kFrameTime));
  }

  static inline int instances_ = 0;
  std::filesystem::path dir_;
  config::Config config_;
  device::DeviceCatalog catalog_;
  std::unique_ptr<StateStore> store_;
  FakeBusClock clock_;
  can::VirtualBus bus_;
  can::VirtualBus::Port& gateway_ = bus_.attach();
  std::vector<std::unique_ptr<device::DeviceDescription>> descriptions_;
  std::vector<Encoder> devices_;
  std::unique_ptr<BusManager> manager_;
  TimePoint next_{};
};

}  // namespace cobridge::gateway::test
