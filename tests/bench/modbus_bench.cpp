// Modbus output benchmark (docs/performance.md): requests/s answered by
// libcobridge_modbus.so with 32 clients on the loopback while a feeder pushes
// 36 000 samples/s (32 devices) through PluginHost::deliver, as the
// dispatcher would at four saturated 1 Mbit/s CAN buses. Each client is a
// thread doing blocking request/response (read 28 registers of one device
// slot, function 0x03) as fast as it can. Prints figures; not a test.
//
// Usage: cobridge_bench_modbus [PLUGIN.so] [SECONDS] [CLIENTS] [SAMPLES_PER_S]
// (the plugin defaults to the build tree's lib/cobridge/plugins/).
#include "pipeline/plugin_host.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <mutex>
#include <regex>
#include <string>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

std::uint64_t realtime_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000u + static_cast<std::uint64_t>(ts.tv_nsec);
}

bool recv_all(int fd, std::uint8_t* p, std::size_t n) {
  while (n > 0) {
    const ssize_t r = ::recv(fd, p, n, 0);
    if (r <= 0) return false;
    p += r;
    n -= static_cast<std::size_t>(r);
  }
  return true;
}

struct ClientResult {
  std::uint64_t requests = 0;
  std::uint64_t errors = 0;
  std::vector<std::uint32_t> latency_us;
};

void client(std::uint16_t port, int index, const std::atomic<bool>& go, const std::atomic<bool>& stop,
            ClientResult& out) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0) {
    ++out.errors;
    ::close(fd);
    return;
  }
  const int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  out.latency_us.reserve(1 << 20);
  while (!go.load()) std::this_thread::yield();
  std::uint16_t tid = 0;
  std::uint8_t resp[260];
  while (!stop.load(std::memory_order_relaxed)) {
    ++tid;
    const auto address = static_cast<std::uint16_t>(256 + 32 * (index % 32));
    const std::uint8_t req[12] = {static_cast<std::uint8_t>(tid >> 8), static_cast<std::uint8_t>(tid), 0, 0, 0, 6, 1, 0x03,
                                  static_cast<std::uint8_t>(address >> 8), static_cast<std::uint8_t>(address), 0, 28};
    const auto t0 = Clock::now();
    if (::send(fd, req, sizeof req, MSG_NOSIGNAL) != static_cast<ssize_t>(sizeof req) || !recv_all(fd, resp, 9) ||
        resp[7] != 0x03 || !recv_all(fd, resp + 9, resp[8])) {
      ++out.errors;
      break;
    }
    const auto us = std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - t0).count();
    ++out.requests;
    if (out.latency_us.size() < out.latency_us.capacity()) out.latency_us.push_back(static_cast<std::uint32_t>(us));
  }
  ::close(fd);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace cobridge::pipeline;
  std::filesystem::path plugin;
  if (argc > 1) {
    plugin = argv[1];
  } else {  // the build tree's plugin directory, or the plugin's own folder
    const auto build = std::filesystem::read_symlink("/proc/self/exe").parent_path() / "../..";
    plugin = build / "lib/cobridge/plugins/libcobridge_modbus.so";
    if (!std::filesystem::exists(plugin)) plugin = build / "plugins/modbus/libcobridge_modbus.so";
  }
  const double seconds = argc > 2 ? std::atof(argv[2]) : 5.0;
  const int clients = argc > 3 ? std::atoi(argv[3]) : 32;
  const int rate = argc > 4 ? std::atoi(argv[4]) : 36000;
  constexpr int kDevices = 32;

  std::mutex log_mutex;
  std::string listening;
  PluginHost::Options options;
  options.gateway_id = "bench";
  options.log = [&](LogLevel, std::string_view, std::string_view msg) {
    std::lock_guard lock(log_mutex);
    if (msg.find("listening on") != std::string_view::npos) listening = msg;
  };
  options.plugin_dir = std::filesystem::path(plugin).parent_path();  // plugins load from their directory only
  PluginHost host(options);
  PluginSpec spec{"modbus", "modbus", std::filesystem::path(plugin).filename(),
                  "bind = \"127.0.0.1\"\nport = 0\nmax_clients = 64\n"};
  const cobridge::Error error = host.load(spec);
  if (error || !host.start_all().empty()) {
    std::fprintf(stderr, "cannot load %s: %s\n", plugin.c_str(), error.message.c_str());
    return 1;
  }
  std::smatch m;
  std::uint16_t port = 0;
  {
    std::lock_guard lock(log_mutex);
    if (std::regex_search(listening, m, std::regex(R"(:(\d+) )"))) port = static_cast<std::uint16_t>(std::stoi(m[1]));
  }
  if (port == 0) {
    std::fprintf(stderr, "no port in the plugin's log\n");
    return 1;
  }

  std::atomic<bool> go{false};
  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> fed{0};
  // Feeder: the dispatcher's role, one batch per millisecond.
  std::thread feeder([&] {
    std::vector<Sample> batch(static_cast<std::size_t>(rate / 1000));
    std::vector<std::uint32_t> seq(kDevices, 0);
    std::size_t next_device = 0;
    timespec next{};
    clock_gettime(CLOCK_MONOTONIC, &next);
    while (!stop.load()) {
      const std::uint64_t now = realtime_ns();
      for (Sample& s : batch) {
        s = Sample{};
        const auto d = static_cast<std::uint16_t>(next_device++ % kDevices);
        s.device_index = d;
        s.bus_index = static_cast<std::uint8_t>(d % 4);
        s.node_id = static_cast<std::uint8_t>(d + 1);
        s.kind = COBRIDGE_SAMPLE_TPDO;
        s.sequence = ++seq[d];
        s.rx_timestamp_ns = now;
        s.valid = COBRIDGE_VALID_POSITION | COBRIDGE_VALID_SPEED;
        s.position = static_cast<std::int64_t>(s.sequence) * 3;
      }
      host.deliver(batch);
      fed.fetch_add(batch.size(), std::memory_order_relaxed);
      next.tv_nsec += 1'000'000;
      if (next.tv_nsec >= 1'000'000'000L) {
        next.tv_nsec -= 1'000'000'000L;
        ++next.tv_sec;
      }
      clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr);
    }
  });

  std::vector<ClientResult> results(static_cast<std::size_t>(clients));
  std::vector<std::thread> threads;
  for (int i = 0; i < clients; ++i) {
    threads.emplace_back(client, port, i, std::cref(go), std::cref(stop), std::ref(results[static_cast<std::size_t>(i)]));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const std::uint64_t fed0 = fed.load();
  const auto t0 = Clock::now();
  go = true;
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  stop = true;
  const double elapsed = std::chrono::duration<double>(Clock::now() - t0).count();
  const std::uint64_t fed1 = fed.load();
  for (auto& t : threads) t.join();
  feeder.join();
  host.stop_all();

  std::uint64_t total = 0;
  std::uint64_t errors = 0;
  std::vector<std::uint32_t> lat;
  for (const auto& r : results) {
    total += r.requests;
    errors += r.errors;
    lat.insert(lat.end(), r.latency_us.begin(), r.latency_us.end());
  }
  std::sort(lat.begin(), lat.end());
  const auto pct = [&](double p) { return lat.empty() ? 0u : lat[static_cast<std::size_t>(p * static_cast<double>(lat.size() - 1))]; };
  std::printf("modbus: %d clients, %.1f s, feeder %.0f samples/s (target %d)\n", clients, elapsed,
              static_cast<double>(fed1 - fed0) / elapsed, rate);
  std::printf("modbus: %.0f requests/s (read 28 registers, 0x03), %llu errors\n", static_cast<double>(total) / elapsed,
              static_cast<unsigned long long>(errors));
  std::printf("modbus: round trip p50 %u us, p99 %u us, max %u us\n", pct(0.5), pct(0.99), lat.empty() ? 0u : lat.back());
  return errors == 0 ? 0 : 1;
}
