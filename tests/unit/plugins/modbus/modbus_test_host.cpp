// modbus_test_host: a stand-in for cobridged in the Modbus end-to-end tests.
// It loads libcobridge_modbus.so through the real PluginHost (dlopen),
// announces N devices, and feeds TPDO samples on a timer until it gets
// SIGTERM/SIGINT. Plugin log lines go to stdout ("LOG <level> <text>"), which
// is how the test learns the bound port (config port = 0).
//
// Values are a function of the device and its sequence number, so a reader
// can check any register it gets against the sequence it got with it:
//   position = device * 1 000 000 + sequence, speed = device * 10 + 1,
//   temperature_dC = 200 + device, voltage_dV = 240, cam_state = sequence & 0xFF,
//   node_id = device + 1, bus = device % 2, serial = 1000 + device.
//
// Usage: modbus_test_host PLUGIN CONFIG_TOML DEVICES RATE_HZ [--offline K] [--frozen K]
//   --offline K  device K is reported offline (STATUS online = 0)
//   --frozen K   device K gets one sample at start, then none (its data age grows)
//
// Commands (plugin ABI 2, host->submit_command) are printed ("COMMAND device=
// kind= tag= value=") and answered 300 ms later with a COMMAND sample, as the
// daemon would: done, or refused by the device (abort 0x06090030) for a
// preset of -1; a device index beyond DEVICES is refused at once.
#include "pipeline/plugin_host.hpp"

#include <chrono>
#include <filesystem>
#include <csignal>
#include <mutex>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>
#include <vector>

namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

std::uint64_t realtime_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000u + static_cast<std::uint64_t>(ts.tv_nsec);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace cobridge::pipeline;
  if (argc < 5) {
    std::fprintf(stderr, "usage: %s PLUGIN CONFIG_TOML DEVICES RATE_HZ [--offline K] [--frozen K]\n", argv[0]);
    return 2;
  }
  const std::string plugin = argv[1];
  const std::string config = argv[2];
  const int devices = std::atoi(argv[3]);
  const int rate = std::atoi(argv[4]);
  int offline = -1;
  int frozen = -1;
  for (int i = 5; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--offline") == 0) offline = std::atoi(argv[i + 1]);
    if (std::strcmp(argv[i], "--frozen") == 0) frozen = std::atoi(argv[i + 1]);
  }
  std::signal(SIGTERM, on_signal);
  std::signal(SIGINT, on_signal);

  struct Pending {
    cobridge_command command;
    std::chrono::steady_clock::time_point due;
  };
  std::mutex pending_mutex;
  std::vector<Pending> pending;

  PluginHost::Options options;
  options.gateway_id = "test";
  options.commands = [&](std::string_view, const cobridge_command& c) -> int {
    if (c.device_index >= devices) return COBRIDGE_COMMAND_UNKNOWN_DEVICE;
    std::printf("COMMAND device=%u kind=%u tag=%u value=%lld\n", static_cast<unsigned>(c.device_index),
                static_cast<unsigned>(c.kind), c.tag, static_cast<long long>(c.value));
    std::fflush(stdout);
    const std::lock_guard lock(pending_mutex);
    pending.push_back({c, std::chrono::steady_clock::now() + std::chrono::milliseconds(300)});
    return COBRIDGE_COMMAND_OK;
  };
  options.log = [](LogLevel level, std::string_view, std::string_view msg) {
    std::printf("LOG %d %.*s\n", static_cast<int>(level), static_cast<int>(msg.size()), msg.data());
    std::fflush(stdout);
  };
  // Plugins load from their directory only (plugin_trust.hpp): the given file's.
  options.plugin_dir = std::filesystem::path(plugin).parent_path();
  PluginHost host(options);
  PluginSpec spec;
  spec.instance = "modbus";
  spec.type = "modbus";
  spec.file = std::filesystem::path(plugin).filename();
  spec.config_toml = config;
  if (const cobridge::Error error = host.load(spec)) {
    std::printf("ERROR %s\n", error.message.c_str());
    return 1;
  }
  if (!host.start_all().empty()) {
    std::printf("ERROR start failed\n");
    return 1;
  }

  std::vector<std::uint32_t> seq(static_cast<std::size_t>(devices), 0);
  for (int d = 0; d < devices; ++d) {
    cobridge_device_info info{};
    info.struct_size = sizeof info;
    info.device_index = static_cast<std::uint16_t>(d);
    info.bus_index = static_cast<std::uint8_t>(d % 2);
    info.node_id = static_cast<std::uint8_t>(d + 1);
    info.change = COBRIDGE_DEVICE_ADDED;
    info.vendor_id = 0x12D;
    info.product_code = 0x100u + static_cast<std::uint32_t>(d);
    info.serial = 1000u + static_cast<std::uint32_t>(d);
    info.name = info.bus_name = info.model = info.family = info.position_unit = "";
    host.announce(info);
  }
  std::vector<Sample> batch;
  batch.reserve(static_cast<std::size_t>(devices));
  const auto make = [&](int d, std::uint8_t kind) {
    Sample s{};
    const auto i = static_cast<std::size_t>(d);
    s.sequence = ++seq[i];
    s.device_index = static_cast<std::uint16_t>(d);
    s.bus_index = static_cast<std::uint8_t>(d % 2);
    s.node_id = static_cast<std::uint8_t>(d + 1);
    s.kind = kind;
    s.rx_timestamp_ns = realtime_ns();
    s.publish_timestamp_ns = s.rx_timestamp_ns;
    return s;
  };
  for (int d = 0; d < devices; ++d) {
    Sample s = make(d, COBRIDGE_SAMPLE_STATUS);
    s.valid = COBRIDGE_VALID_STATUS | COBRIDGE_VALID_NMT_STATE;
    s.online = d == offline ? 0 : 1;
    s.nmt_state = d == offline ? 0 : COBRIDGE_NMT_OPERATIONAL;
    batch.push_back(s);
  }
  host.deliver(batch);

  const long period_ns = rate > 0 ? 1'000'000'000L / rate : 1'000'000L;
  timespec next{};
  clock_gettime(CLOCK_MONOTONIC, &next);
  bool first = true;
  while (g_stop == 0) {
    batch.clear();
    for (int d = 0; d < devices; ++d) {
      if (d == frozen && !first) continue;
      Sample s = make(d, COBRIDGE_SAMPLE_TPDO);
      const std::uint32_t q = s.sequence;
      s.valid = COBRIDGE_VALID_POSITION | COBRIDGE_VALID_SPEED | COBRIDGE_VALID_CAM_STATE | COBRIDGE_VALID_TEMPERATURE |
                COBRIDGE_VALID_VOLTAGE;
      s.position = static_cast<std::int64_t>(d) * 1'000'000 + q;
      s.speed = d * 10 + 1;
      s.cam_state = static_cast<std::uint8_t>(q & 0xFF);
      s.temperature_dC = static_cast<std::int16_t>(200 + d);
      s.voltage_dV = 240;
      batch.push_back(s);
    }
    {
      const std::lock_guard lock(pending_mutex);
      const auto now = std::chrono::steady_clock::now();
      for (auto it = pending.begin(); it != pending.end();) {
        if (it->due > now) {
          ++it;
          continue;
        }
        Sample s = make(it->command.device_index, COBRIDGE_SAMPLE_COMMAND);
        s.valid = COBRIDGE_VALID_COMMAND;
        s.command_kind = it->command.kind;
        s.command_tag = it->command.tag;
        const bool refuse = it->command.kind == COBRIDGE_COMMAND_PRESET && it->command.value == -1;
        s.command_status = refuse ? COBRIDGE_COMMAND_REFUSED : COBRIDGE_COMMAND_OK;
        s.command_abort_code = refuse ? 0x06090030u : 0u;
        batch.push_back(s);
        it = pending.erase(it);
      }
    }
    host.deliver(batch);
    if (first) {  // every device has process data now
      std::printf("READY\n");
      std::fflush(stdout);
      first = false;
    }
    next.tv_nsec += period_ns;
    while (next.tv_nsec >= 1'000'000'000L) {
      next.tv_nsec -= 1'000'000'000L;
      ++next.tv_sec;
    }
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
  }
  host.stop_all();
  host.unload_all();
  std::printf("STOPPED\n");
  return 0;
}
