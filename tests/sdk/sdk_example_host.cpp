// Loads the out-of-tree example plugin (examples/plugin-minimal, built
// against the *installed* SDK by run_sdk_example.sh) through the daemon's
// PluginHost and checks what it reports: the EMCY meaning it got from
// <cobridge/emcy.h> is the canopen layer's own text for the device family
// (one table for the daemon and the plugins).
//
// The plugin directory comes from COBRIDGE_SDK_EXAMPLE_DIR; the test is run
// only by the sdk_example ctest test, after the script built the plugin.
#include "families/novotechnik.hpp"
#include "families/novotechnik_rotary.hpp"
#include "pipeline/plugin_host.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <mutex>
#include <string>
#include <vector>

namespace {

using namespace cobridge;

struct Lines {
  std::mutex mutex;
  std::vector<std::string> lines;
  pipeline::PluginHost::LogSink sink() {
    return [this](pipeline::LogLevel, std::string_view, std::string_view msg) {
      const std::lock_guard lock(mutex);
      lines.emplace_back(msg);
    };
  }
};

cobridge_sample emcy_sample(uint16_t device_index, uint8_t node, uint16_t code) {
  cobridge_sample s{};
  s.kind = COBRIDGE_SAMPLE_EMCY;
  s.valid = COBRIDGE_VALID_EMCY;
  s.device_index = device_index;
  s.node_id = node;
  s.emcy_code = code;
  s.emcy_register = 0x01;
  return s;
}

TEST(SdkExample, InstalledSdkPluginLoadsAndNamesEmcyFromTheOneTable) {
  const char* dir = std::getenv("COBRIDGE_SDK_EXAMPLE_DIR");
  ASSERT_NE(dir, nullptr) << "run through tests/sdk/run_sdk_example.sh";
  Lines log;
  pipeline::PluginHost host({dir, "gw-sdk", log.sink()});
  const Error error = host.load({"example", "emcylog", {}, {}});
  ASSERT_FALSE(error) << error.to_string();
  ASSERT_TRUE(host.start_all().empty());

  cobridge_device_info info{};
  info.struct_size = sizeof info;
  info.device_index = 3;
  info.node_id = 5;
  info.name = info.bus_name = info.model = info.position_unit = "";
  info.family = "novotechnik-rotary";
  host.announce(info);
  const std::array<cobridge_sample, 2> batch = {emcy_sample(3, 5, 0x8130), emcy_sample(3, 5, 0x9080)};
  host.deliver(batch);
  host.stop_all();

  // The row of the rotary family's module (J§1.8.1) the SDK must have given.
  const auto& table = *cobridge::families::kNovotechnikRotary.emcy;
  const auto* want = table.find(0x9080, 0x01, {});
  ASSERT_NE(want, nullptr) << "0x9080 is a row of the rotary manual's table (J§1.8.1)";
  const std::string expected = "emcylog: 2 EMCY; last: node 5 0x9080 " + std::string(want->text) + " (" +
                               std::string(table.source) + ")";
  // The host logs its own lines (loaded, started) through the same sink.
  const std::lock_guard lock(log.mutex);
  std::string all;
  for (const auto& l : log.lines) all += l + "\n";
  EXPECT_NE(std::find(log.lines.begin(), log.lines.end(), "emcylog: started"), log.lines.end()) << all;
  EXPECT_NE(std::find(log.lines.begin(), log.lines.end(), expected), log.lines.end())
      << "expected \"" << expected << "\" in:\n" << all;
}

}  // namespace
