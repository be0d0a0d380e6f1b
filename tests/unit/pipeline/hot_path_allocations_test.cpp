// The hot path allocates nothing per frame (issue 24: a promise asserted in
// CI, not only printed by a bench). The path as the daemon runs it: TPDO
// frames -> BusReceiver (FrameDecoder, DecodePlan) -> SPSC ring -> Dispatcher
// -> PluginHost -> the real Modbus and JSON tap plugins (their on_samples run
// on the dispatcher's thread). malloc, calloc and realloc are interposed for
// the whole process (tests/bench/alloc_counter.cpp) and counted over 64,000
// frames after a warm-up. A count, not a time: it cannot flake. Not built in
// the sanitizer builds (their runtimes own malloc).
#include "alloc_counter.hpp"
#include "rotary_fleet.hpp"
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

TEST(HotPathAllocations, ZeroPerFrameThroughModbusAndTheJsonTap) {
  DeviceTable table;
  std::string err;
  ASSERT_TRUE(bench::publish_rotary_fleet(table, kDevices, err)) << err;
  PluginHost host(PluginHost::Options{.plugin_dir = COBRIDGE_TEST_PLUGIN_DIR,
                                      .gateway_id = "alloc",
                                      .log = [](LogLevel, std::string_view, std::string_view) {}});
  ASSERT_FALSE(host.load(PluginSpec{"modbus", "modbus", {}, "bind = \"127.0.0.1\"\nport = 0\n"}));
  ASSERT_FALSE(host.load(PluginSpec{"jsontap", "jsontap", {}, "path = \"/dev/null\"\n"}));
  ASSERT_TRUE(host.start_all().empty());
  bench::announce_rotary_fleet(host, kDevices);

  HostSink sink(host);
  Dispatcher dispatcher(sink);  // not started: drained on this thread
  BusReceiver rx(BusReceiverOptions{.bus_index = 0, .interface = {}, .ring_capacity = 4096}, table, dispatcher);
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
  bench::start_counting_allocations();
  for (int r = 0; r < kRounds; ++r) {
    for (auto& f : batch) f.data[0] = static_cast<std::uint8_t>(r);
    rx.handle(batch);
    dispatcher.drain_once();
  }
  const unsigned long long allocs = bench::stop_counting_allocations();
  host.stop_all();
  EXPECT_EQ(sink.delivered, kRounds * batch.size()) << "every frame reached the plugins";
  EXPECT_EQ(rx.stats().ring_drops, 0U);
  EXPECT_EQ(allocs, 0U) << "heap allocations in " << kRounds * batch.size() << " frames";
}

}  // namespace
}  // namespace cobridge::pipeline
