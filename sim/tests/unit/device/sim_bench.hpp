// Test bench for SimDevice: one device on a recording sink, a fake clock,
// helpers that send SDO / NMT / LSS frames and pick the answers out.
// Thread: the test's thread only.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <unistd.h>

#include "can/frame.hpp"
#include "can/frame_sink.hpp"
#include "device/eds.hpp"
#include "device/sim_device.hpp"

namespace cobridge::sim::test {

using namespace std::chrono_literals;
using can::Frame;

inline std::filesystem::path devices_dir() {
  return std::filesystem::path(__FILE__).parent_path() / "../../../../config/devices";
}

inline device::DeviceDescription load_description(const std::string& file) {
  auto r = device::load_eds_file(devices_dir() / file);
  if (!r.ok()) {
    std::string all;
    for (const auto& e : r.errors) all += e.to_string() + "\n";
    ADD_FAILURE() << all;
    return {};
  }
  return *r.description;
}

struct Recorder final : can::FrameSink {
  std::vector<Frame> frames;
  bool send(const Frame& f) noexcept override {
    frames.push_back(f);
    return true;
  }
};

class Bench {
 public:
  Bench(const std::string& model, const std::string& eds, DeviceSpec spec = {},
        std::filesystem::path state_dir = {})
      : desc_(load_description(eds)) {
    spec.model = find_model(model);
    if (spec.serial == 0) spec.serial = 0x12345678;
    device = std::make_unique<SimDevice>(spec, desc_, rec, std::move(state_dir));
    device->set_truth_sink([this](const TruthRecord& r) { truth.push_back(r); });
  }

  void power_on() { ASSERT_FALSE(device->power_on(now)); }
  void power_cycle() { ASSERT_FALSE(device->power_cycle(now)); }

  // Runs the device's own schedule up to `until` (inclusive).
  void run_until(canopen::TimePoint until) {
    for (int guard = 0; guard < 50'000'000; ++guard) {
      const canopen::TimePoint next = device->process(now);
      if (next > until) break;
      now = next > now ? next : now + 1us;
    }
    now = until;
    (void)device->process(now);
  }
  void run_for(canopen::Duration d) { run_until(now + d); }

  void deliver(const Frame& f) { device->on_frame(f, now); }
  void nmt(std::uint8_t cs, std::uint8_t node = 0) { deliver(Frame::make(0x000, {cs, node})); }

  // One SDO request; returns the answer on 0x580+node (or an empty frame).
  Frame sdo(const std::array<std::uint8_t, 8>& request) {
    const std::uint8_t node = device->node_id();
    const std::size_t before = rec.frames.size();
    deliver(Frame::make8(0x600U + node, request));
    for (std::size_t i = before; i < rec.frames.size(); ++i)
      if (rec.frames[i].id == 0x580U + node) return rec.frames[i];
    return Frame{};
  }
  Frame write_u32(std::uint16_t index, std::uint8_t sub, std::uint32_t v) {
    return sdo({0x23, static_cast<std::uint8_t>(index), static_cast<std::uint8_t>(index >> 8), sub,
                static_cast<std::uint8_t>(v), static_cast<std::uint8_t>(v >> 8), static_cast<std::uint8_t>(v >> 16),
                static_cast<std::uint8_t>(v >> 24)});
  }
  Frame write_u16(std::uint16_t index, std::uint8_t sub, std::uint16_t v) {
    return sdo({0x2B, static_cast<std::uint8_t>(index), static_cast<std::uint8_t>(index >> 8), sub,
                static_cast<std::uint8_t>(v), static_cast<std::uint8_t>(v >> 8), 0, 0});
  }
  Frame write_u8(std::uint16_t index, std::uint8_t sub, std::uint8_t v) {
    return sdo({0x2F, static_cast<std::uint8_t>(index), static_cast<std::uint8_t>(index >> 8), sub, v, 0, 0, 0});
  }
  Frame read(std::uint16_t index, std::uint8_t sub) {
    return sdo({0x40, static_cast<std::uint8_t>(index), static_cast<std::uint8_t>(index >> 8), sub, 0, 0, 0, 0});
  }
  static std::uint32_t abort_code(const Frame& f) {
    if (f.data[0] != 0x80) return 0;
    return static_cast<std::uint32_t>(f.data[4] | (f.data[5] << 8) | (f.data[6] << 16)) |
           (static_cast<std::uint32_t>(f.data[7]) << 24);
  }
  static std::uint32_t value(const Frame& f) {
    return static_cast<std::uint32_t>(f.data[4] | (f.data[5] << 8) | (f.data[6] << 16)) |
           (static_cast<std::uint32_t>(f.data[7]) << 24);
  }

  std::vector<Frame> frames_with_id(std::uint32_t id, std::size_t from = 0) const {
    std::vector<Frame> out;
    for (std::size_t i = from; i < rec.frames.size(); ++i)
      if (rec.frames[i].id == id) out.push_back(rec.frames[i]);
    return out;
  }

  device::DeviceDescription desc_;
  Recorder rec;
  std::vector<TruthRecord> truth;
  std::unique_ptr<SimDevice> device;
  canopen::TimePoint now{std::chrono::seconds(1000)};
};

// A fresh, empty state directory per test.
inline std::filesystem::path temp_state_dir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() / ("cobridge-simdev-" + name + "-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  return dir;
}

}  // namespace cobridge::sim::test
