// The daemon starts its output plugins on a helper thread while its buses
// come up (app/daemon.cpp): what the buses produce meanwhile (samples in the
// ring, device announcements posted to the dispatcher) must wait for the
// plugins and reach them all, through the real plugin ABI (test_v1, dlopen).
#include "pipeline/dispatcher.hpp"
#include "pipeline/plugin_host.hpp"
#include "pipeline/spsc_ring.hpp"
#include "unit/pipeline/test_plugins/test_plugin_record.h"
#include "unit/support/eventually.hpp"

#include <dlfcn.h>
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <thread>
#include <vector>

using namespace cobridge::pipeline;
using namespace std::chrono_literals;
using cobridge::test::eventually;

namespace {

const std::filesystem::path kTestPluginDir = COBRIDGE_TEST_PLUGIN_DIR;

class HostSink final : public SampleSink {
 public:
  explicit HostSink(PluginHost& host) : host_(host) {}
  void deliver(std::span<const Sample> batch) noexcept override { host_.deliver(batch); }

 private:
  PluginHost& host_;
};

Sample tpdo(std::uint32_t sequence) {
  Sample s = make_sample(SampleKind::kTpdo, 2, 0, 5, 1'000'000'000ull + sequence);
  s.sequence = sequence;
  set_position(s, sequence);
  return s;
}

}  // namespace

TEST(PluginStartOverlap, NothingProducedWhileThePluginStartsIsLost) {
  // The library the host loads, opened here too to read what the plugin saw.
  void* lib = ::dlopen((kTestPluginDir / "libcobridge_test_v1.so").c_str(), RTLD_NOW | RTLD_LOCAL);
  ASSERT_NE(lib, nullptr) << ::dlerror();
  const auto* seen = static_cast<const test_record*>(::dlsym(lib, TEST_PLUGIN_RECORD));
  ASSERT_NE(seen, nullptr);
  const test_record before = *seen;

  PluginHost host({kTestPluginDir, "gw", [](LogLevel, std::string_view, std::string_view) {}});
  ASSERT_FALSE(host.load(PluginSpec{"tap", "test_v1", {}, {}}));
  HostSink sink(host);
  Dispatcher dispatcher(sink);
  SpscRing<Sample> ring(4096);
  dispatcher.add_source(ring);
  dispatcher.hold();  // as OutputPipeline::start_receivers does

  cobridge_device_info info{};
  info.struct_size = sizeof info;
  info.name = "spindle";
  info.bus_name = "line1";
  info.model = "RM9";
  info.family = "ifm-rm";
  info.position_unit = "counts";
  constexpr std::uint32_t kSamples = 1000;
  // The bus: samples and, now and then, an announcement (OutputBridge::announce).
  std::thread bus([&] {
    for (std::uint32_t i = 1; i <= kSamples; ++i) {
      while (!ring.try_push(tpdo(i))) std::this_thread::yield();
      dispatcher.wake();
      if (i % 250 == 0) dispatcher.post([&host, info] { host.announce(info); });
    }
  });
  // The helper thread: the plugins start, then the dispatcher delivers what waited.
  std::vector<cobridge::Error> problems;
  std::thread starter([&] {
    problems = host.start_all();
    dispatcher.start();
  });
  bus.join();
  starter.join();
  EXPECT_TRUE(problems.empty());
  EXPECT_TRUE(eventually([&] { return dispatcher.stats().samples == kSamples; }, 10s));
  dispatcher.stop();  // joins the thread that wrote the record

  EXPECT_EQ(seen->started - before.started, 1);
  EXPECT_EQ(seen->samples_seen - before.samples_seen, kSamples);
  EXPECT_EQ(seen->position_sum - before.position_sum, static_cast<long long>(kSamples) * (kSamples + 1) / 2);
  EXPECT_EQ(seen->on_device_calls - before.on_device_calls, 4) << "an announcement run before the start is lost";
  EXPECT_EQ(seen->last_sample.sequence, kSamples);
  host.unload_all();
  ::dlclose(lib);
}
