// Hot-path benchmark: CAN frames -> FrameDecoder -> SPSC ring -> Dispatcher
// -> output plugins, all on ONE core (the RX side and the dispatcher run on
// the same thread, alternating per batch), so the figure is the cost per frame
// of the whole path, not of two cores working in parallel.
//
// Also counts heap allocations per frame by interposing malloc/calloc/realloc
// for the timed loop (every allocation in the process, plugins included), and
// prints the RSS with 32 devices.
//
// Usage: cobridge_bench_pipeline [--frames N] [--rate R] [--plugins DIR] [--with a,b,c]
//   --with takes plugin names (jsontap, dds, modbus); each is loaded from DIR
//   with its default settings (jsontap writes to /dev/null).
//   --rate R paces the feed at R frames/s (default: as fast as the one core
//   goes). Plugins with a thread of their own (DDS writes from its writer
//   thread) are not part of the one-core figure; what they could not keep up
//   with they drop and count, and say so when stopped: the plugin log lines
//   are printed after the run, so a rate is only sustained through DDS if
//   its writer dropped nothing. The main thread's CPU time at that rate is
//   the RX + dispatcher cost.
//   --recorder S: the flight recorder on, S seconds at 1000 kbit/s (every
//   frame into its ring, as the RX thread does); compare with a run without.
#include "alloc_counter.hpp"
#include "pipeline/bus_receiver.hpp"
#include "pipeline/dispatcher.hpp"
#include "pipeline/plugin_host.hpp"

#include <dlfcn.h>
#include <time.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>


using namespace cobridge;
using namespace cobridge::pipeline;

namespace {

class CountingSink : public SampleSink {
 public:
  explicit CountingSink(PluginHost* host) : host_(host) {}
  void deliver(std::span<const Sample> batch) noexcept override {
    delivered += batch.size();
    if (host_) host_->deliver(batch);
  }
  PluginHost* host_;
  std::size_t delivered = 0;
};

double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

long rss_kib() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::strtol(line.c_str() + 6, nullptr, 10);
  return -1;
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t frames_total = 2'000'000;
  double rate = 0;
  std::string plugin_dir;
  std::string with;
  unsigned recorder_s = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--frames" && i + 1 < argc) frames_total = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--rate" && i + 1 < argc) rate = std::strtod(argv[++i], nullptr);
    else if (a == "--plugins" && i + 1 < argc) plugin_dir = argv[++i];
    else if (a == "--with" && i + 1 < argc) with = argv[++i];
    else if (a == "--recorder" && i + 1 < argc) recorder_s = static_cast<unsigned>(std::strtoul(argv[++i], nullptr, 10));
    else {
      std::fprintf(stderr, "usage: %s [--frames N] [--rate FRAMES_PER_S] [--plugins DIR] [--with jsontap,dds,modbus] [--recorder S]\n",
                   argv[0]);
      return 2;
    }
  }

  // 32 devices on one bus, rotary default mapping (J§1.7.2): pos i32 | speed i16.
  constexpr int kDevices = 32;
  DeviceTable table;
  for (int n = 1; n <= kDevices; ++n) {
    DecodePlan p;
    p.active = true;
    p.indexed = true;
    p.node_id = static_cast<std::uint8_t>(n);
    p.device_index = static_cast<std::uint16_t>(n - 1);
    std::vector<MappedObject> map = {{0x60200120, true}, {0x60300110, true}};
    (void)build_pdo_decode(map, p.tpdo[0]);
    table.publish(p);
  }

  std::mutex log_mutex;
  std::vector<std::string> plugin_log;
  PluginHost host(PluginHost::Options{
      .plugin_dir = plugin_dir,
      .gateway_id = "bench",
      .log = [&](LogLevel, std::string_view instance, std::string_view msg) {
        const std::lock_guard lock(log_mutex);
        plugin_log.push_back(std::string(instance) + ": " + std::string(msg));
      }});
  std::vector<std::string> loaded;
  if (!with.empty()) {
    std::size_t pos = 0;
    while (pos <= with.size()) {
      const std::size_t comma = with.find(',', pos);
      const std::string name = with.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
      pos = comma == std::string::npos ? with.size() + 1 : comma + 1;
      if (name.empty()) continue;
      PluginSpec spec;
      spec.instance = name;
      spec.type = name;
      if (name == "jsontap") spec.config_toml = "path = \"/dev/null\"\n";
      if (const cobridge::Error err = host.load(spec)) {
        std::fprintf(stderr, "plugin %s: %s\n", name.c_str(), err.message.c_str());
        return 1;
      }
      loaded.push_back(name);
    }
    for (const auto& e : host.start_all()) {
      std::fprintf(stderr, "start: %s\n", e.message.c_str());
      return 1;
    }
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

  CountingSink sink(loaded.empty() ? nullptr : &host);
  Dispatcher dispatcher(sink);  // not started: drained on this thread
  std::unique_ptr<can::FrameRecorder> recorder;
  if (recorder_s > 0) recorder = std::make_unique<can::FrameRecorder>(can::FrameRecorder::capacity_for(1000, recorder_s));
  BusReceiver rx(BusReceiverOptions{.bus_index = 0, .interface = {}, .ring_capacity = 4096, .recorder = recorder.get()},
                 table, dispatcher);
  dispatcher.add_source(rx.ring());

  // A batch as recvmmsg would return it: 64 TPDOs round-robin over the devices.
  std::vector<can::Frame> batch(64);
  const auto t_real = std::chrono::system_clock::now().time_since_epoch();
  const auto base_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(t_real).count();
  for (std::size_t i = 0; i < batch.size(); ++i) {
    batch[i] = can::Frame::make(0x180 + 1 + (i % kDevices), {0x10, 0x20, 0x00, 0x00, 0x05, 0x00});
    batch[i].timestamp_ns = base_ns;
  }

  // Warm-up (first-touch allocations of plugins, page faults).
  for (int w = 0; w < 200; ++w) {
    rx.handle(batch);
    dispatcher.drain_once();
  }
  const long rss_before = rss_kib();
  sink.delivered = 0;

  const std::size_t rounds = frames_total / batch.size();
  const std::uint64_t recorded_before = recorder ? recorder->recorded() : 0;
  bench::start_counting_allocations();
  const double cpu0 = thread_cpu_s();
  const auto t0 = std::chrono::steady_clock::now();
  for (std::size_t r = 0; r < rounds; ++r) {
    if (rate > 0) {
      const auto due = t0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                std::chrono::duration<double>(static_cast<double>(r * batch.size()) / rate));
      std::this_thread::sleep_until(due);
    }
    for (auto& f : batch) f.data[0] = static_cast<std::uint8_t>(r);
    rx.handle(batch);
    dispatcher.drain_once();
  }
  const auto t1 = std::chrono::steady_clock::now();
  const double cpu = thread_cpu_s() - cpu0;
  const unsigned long long allocs = bench::stop_counting_allocations();
  const double secs = std::chrono::duration<double>(t1 - t0).count();
  const std::size_t frames = rounds * batch.size();
  const auto st = rx.stats();

  std::string plugins;
  for (const auto& p : loaded) plugins += (plugins.empty() ? "" : "+") + p;
  if (plugins.empty()) plugins = "none (counting sink)";
  std::printf("pipeline one core: plugins=%s devices=%d frames=%zu\n", plugins.c_str(), kDevices, frames);
  if (rate > 0) std::printf("  paced at        : %.0f frames/s\n", rate);
  if (recorder) {
    std::printf("  flight recorder : %u s, %zu frames, %zu KiB\n", recorder_s, recorder->capacity(),
                recorder->memory_bytes() / 1024);
    std::printf("  recorded        : %llu of %zu frames\n",
                static_cast<unsigned long long>(recorder->recorded() - recorded_before), frames);
  }
  std::printf("  throughput      : %.0f frames/s (%.1f ns/frame)\n", static_cast<double>(frames) / secs,
              secs * 1e9 / static_cast<double>(frames));
  std::printf("  RX + dispatcher : %.1f%% of one core (%.1f ns CPU/frame)\n", 100.0 * cpu / secs,
              cpu * 1e9 / static_cast<double>(frames));
  std::printf("  delivered       : %zu samples, ring drops %llu\n", sink.delivered,
              static_cast<unsigned long long>(st.ring_drops));
  std::printf("  heap allocations: %llu in the timed loop = %.6f per frame\n",
              allocs, static_cast<double>(allocs) / static_cast<double>(frames));
  std::printf("  RSS             : %ld KiB after warm-up, %ld KiB after the run\n", rss_before, rss_kib());
  host.stop_all();  // the DDS writer drains its queue and reports what it dropped
  {
    const std::lock_guard lock(log_mutex);
    for (const auto& line : plugin_log)
      if (line.find("stopped") != std::string::npos) std::printf("  plugin          : %s\n", line.c_str());
  }
  return sink.delivered == frames && st.ring_drops == 0 ? 0 : 1;
}
