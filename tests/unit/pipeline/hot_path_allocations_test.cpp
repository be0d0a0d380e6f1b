// The hot path allocates nothing per frame (a promise asserted in
// CI, not only printed by a bench). The path as the daemon runs it: TPDO
// frames -> BusReceiver (FrameDecoder, DecodePlan) -> SPSC ring -> Dispatcher
// -> PluginHost -> the real Modbus and JSON tap plugins (their on_samples run
// on the dispatcher's thread). malloc, calloc and realloc are interposed for
// the whole process (tests/bench/alloc_counter.cpp) and counted over 64,000
// frames after a warm-up. The flight recorder is on (docs/operations.md
// "Flight recorder": every frame into its ring, no allocation). A count, not a time: it cannot flake. Not built in
// the sanitizer builds (their runtimes own malloc).
#include "alloc_counter.hpp"
#include "pipeline/bus_receiver.hpp"
#include "pipeline/dispatcher.hpp"
#include "pipeline/plugin_host.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

namespace cobridge::pipeline {
namespace {

constexpr int kDevices = 32;

class HostSink : public SampleSink {
 public:
  explicit HostSink(PluginHost& host) : host_(host) {}
  void deliver(std::span<const Sample> batch) noexcept override {
    delivered += batch.size();
    host_.deliver(batch);
  }
  std::size_t delivered = 0;

 private:
  PluginHost& host_;
};

// 32 rotary encoders, default TPDO1 mapping (J§1.7.2: position INTEGER32,
// speed INTEGER16).
void add_devices(DeviceTable& table) {
  for (int n = 1; n <= kDevices; ++n) {
    DecodePlan p;
    p.active = true;
    p.indexed = true;
    p.node_id = static_cast<std::uint8_t>(n);
    p.device_index = static_cast<std::uint16_t>(n - 1);
    const std::vector<MappedObject> map = {{0x60200120, true}, {0x60300110, true}};
    const cobridge::Error err = build_pdo_decode(map, p.tpdo[0]);
    ASSERT_TRUE(err.ok()) << err.message;
    table.publish(p);
  }
}

void announce(PluginHost& host) {
  for (int n = 1; n <= kDevices; ++n) {
    cobridge_device_info info{};
    info.struct_size = sizeof info;
    info.device_index = static_cast<std::uint16_t>(n - 1);
    info.node_id = static_cast<std::uint8_t>(n);
    info.change = COBRIDGE_DEVICE_ADDED;
    const std::string name = "enc" + std::to_string(n);
    info.name = name.c_str();
    info.bus_name = "vcan0";
    info.model = "RFC-4800";
    info.family = "novotechnik-rotary";
    info.position_unit = "counts";
    host.announce(info);
  }
}

// Frames through the receiver, the dispatcher and the loaded plugins after a
// warm-up; the allocations counted over them (every thread, or only this one:
// the RX and dispatcher work runs here).
void expect_no_allocations(PluginHost& host, bool this_thread_only) {
  DeviceTable table;
  add_devices(table);
  ASSERT_TRUE(host.start_all().empty());
  announce(host);

  HostSink sink(host);
  Dispatcher dispatcher(sink);  // not started: drained on this thread
  can::FrameRecorder recorder(can::FrameRecorder::capacity_for(1000, 10));
  BusReceiver rx(BusReceiverOptions{.bus_index = 0, .interface = {}, .ring_capacity = 4096, .recorder = &recorder},
                 table, dispatcher);
  dispatcher.add_source(rx.ring());
  std::vector<can::Frame> batch(64);  // as recvmmsg returns them
  for (std::size_t i = 0; i < batch.size(); ++i)
    batch[i] = can::Frame::make(static_cast<std::uint32_t>(0x181 + (i % kDevices)), {0x10, 0x20, 0, 0, 5, 0});
  for (int w = 0; w < 200; ++w) {  // first-touch work of the plugins
    rx.handle(batch);
    dispatcher.drain_once();
  }
  sink.delivered = 0;

  constexpr int kRounds = 1000;
  this_thread_only ? bench::start_counting_this_thread() : bench::start_counting_allocations();
  for (int r = 0; r < kRounds; ++r) {
    for (auto& f : batch) f.data[0] = static_cast<std::uint8_t>(r);
    rx.handle(batch);
    dispatcher.drain_once();
  }
  const unsigned long long allocs =
      this_thread_only ? bench::stop_counting_this_thread() : bench::stop_counting_allocations();
  host.stop_all();
  EXPECT_EQ(sink.delivered, kRounds * batch.size()) << "every frame reached the plugins";
  EXPECT_EQ(rx.stats().ring_drops, 0U);
  EXPECT_EQ(recorder.recorded(), (200 + kRounds) * batch.size()) << "every frame recorded";
  EXPECT_EQ(allocs, 0U) << "heap allocations in " << kRounds * batch.size() << " frames";
}

PluginHost::Options host_options() {
  return PluginHost::Options{.plugin_dir = COBRIDGE_TEST_PLUGIN_DIR,
                             .gateway_id = "alloc",
                             .log = [](LogLevel, std::string_view, std::string_view) {}};
}

TEST(HotPathAllocations, ZeroPerFrameThroughModbusAndTheJsonTap) {
  PluginHost host(host_options());
  ASSERT_FALSE(host.load(PluginSpec{"modbus", "modbus", {}, "bind = \"127.0.0.1\"\nport = 0\n"}));
  ASSERT_FALSE(host.load(PluginSpec{"jsontap", "jsontap", {}, "path = \"/dev/null\"\n"}));
  expect_no_allocations(host, false);
}

// The Sparkplug output's bound: with the Sparkplug plugin loaded, nothing allocated on
// the RX and dispatcher threads (its publisher and MQTT threads are its own;
// no broker here, so they only retry the connection).
TEST(HotPathAllocations, ZeroPerFrameOnTheDispatcherWithSparkplug) {
  PluginHost host(host_options());
  ASSERT_FALSE(host.load(PluginSpec{"mqtt", "mqtt", {}, "host = \"127.0.0.1\"\nport = 9\n"}));
  expect_no_allocations(host, true);
}

}  // namespace
}  // namespace cobridge::pipeline
