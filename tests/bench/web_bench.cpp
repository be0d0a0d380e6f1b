// Web service bench (against its targets), one run, figures printed:
//  1. the CAN hot path (frames -> decoder -> ring -> dispatcher -> LastValues,
//     the record the web page reads) alone, then while the real WebServer is
//     serving 4 buses x 32 devices to N clients hammering /metrics: ns/frame
//     of both and their ratio, heap allocations made *on the hot-path thread*
//     (other threads' allocations are not the hot path's), samples lost;
//  2. end-to-end request latency (TCP connect .. last byte, a new connection
//     per request as a browser poll or a Prometheus scrape makes it) of /,
//     /api/v1/status and /metrics: p50/p99/max, idle and under the hammering;
//  3. the process RSS before the web service started and after it served.
//
// Usage: cobridge_bench_web [--frames N] [--clients N] [--requests N]
#include "alloc_counter.hpp"
#include "pipeline/bus_receiver.hpp"
#include "pipeline/dispatcher.hpp"
#include "pipeline/last_values.hpp"
#include "web/web_server.hpp"
#include "web_fixture.hpp"

#include <arpa/inet.h>
#include <time.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

using namespace cobridge;
using Clock = std::chrono::steady_clock;

namespace {

constexpr int kBuses = 4;
constexpr int kDevices = 32;

long status_kib(const char* key) {
  std::ifstream f("/proc/self/status");
  std::string line;
  const std::string k = std::string(key) + ":";
  while (std::getline(f, line))
    if (line.rfind(k, 0) == 0) return std::strtol(line.c_str() + k.size(), nullptr, 10);
  return -1;
}

double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

// One GET on a new connection; true when the answer was 200 and complete.
bool http_get(std::uint16_t port, const std::string& path) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  const std::string req = "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
  ok = ok && ::send(fd, req.data(), req.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(req.size());
  std::string got;
  char buf[16384];
  while (ok) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    got.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return ok && got.rfind("HTTP/1.1 200", 0) == 0;
}

struct Latency {
  double p50_ms = 0, p99_ms = 0, max_ms = 0;
  std::size_t failed = 0;
};

Latency measure(std::uint16_t port, const std::string& path, int requests) {
  std::vector<double> ms;
  Latency l;
  for (int i = 0; i < requests; ++i) {
    const auto t0 = Clock::now();
    if (!http_get(port, path)) ++l.failed;
    ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  l.p50_ms = ms[ms.size() / 2];
  l.p99_ms = ms[std::min(ms.size() - 1, ms.size() * 99 / 100)];
  l.max_ms = ms.back();
  return l;
}

// The sink the daemon's dispatcher feeds, minus the plugins: the record the
// web service reads (outputs::OutputPipeline's HostSink does the same).
class LastValuesSink : public pipeline::SampleSink {
 public:
  explicit LastValuesSink(pipeline::LastValues& last) : last_(last) {}
  void deliver(std::span<const pipeline::Sample> batch) noexcept override {
    last_.record(batch);
    delivered += batch.size();
  }
  pipeline::LastValues& last_;
  std::size_t delivered = 0;
};

struct HotPath {
  pipeline::DeviceTable table;
  pipeline::LastValues last{kBuses};
  LastValuesSink sink{last};
  pipeline::Dispatcher dispatcher{sink};  // not started: drained on the calling thread
  std::unique_ptr<pipeline::BusReceiver> rx;
  std::vector<can::Frame> batch = std::vector<can::Frame>(64);

  HotPath() {
    for (int n = 1; n <= kDevices; ++n) {
      pipeline::DecodePlan p;
      p.active = p.indexed = true;
      p.node_id = static_cast<std::uint8_t>(n);
      p.device_index = static_cast<std::uint16_t>(n - 1);
      const std::vector<pipeline::MappedObject> map = {{0x60200120, true}, {0x60300110, true}};
      (void)pipeline::build_pdo_decode(map, p.tpdo[0]);
      table.publish(p);
    }
    rx = std::make_unique<pipeline::BusReceiver>(
        pipeline::BusReceiverOptions{.bus_index = 0, .interface = {}, .ring_capacity = 4096}, table, dispatcher);
    dispatcher.add_source(rx->ring());
    for (std::size_t i = 0; i < batch.size(); ++i)
      batch[i] = can::Frame::make(0x181 + (i % kDevices), {0x10, 0x20, 0x00, 0x00, 0x05, 0x00});
  }

  struct Run {
    double ns_per_frame = 0;
    double cpu_ns_per_frame = 0;  // the hot-path thread's own CPU time
    unsigned long long allocs = 0;
    std::size_t frames = 0, delivered = 0, ring_drops = 0;
  };
  Run run(std::size_t frames) {
    sink.delivered = 0;
    const std::uint64_t drops0 = rx->stats().ring_drops;
    const std::size_t rounds = frames / batch.size();
    bench::start_counting_this_thread();
    const double cpu0 = thread_cpu_s();
    const auto t0 = Clock::now();
    for (std::size_t r = 0; r < rounds; ++r) {
      const std::int64_t now_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
      for (auto& f : batch) {
        f.data[0] = static_cast<std::uint8_t>(r);
        f.timestamp_ns = now_ns;
      }
      rx->handle(batch);
      dispatcher.drain_once();
    }
    const double s = std::chrono::duration<double>(Clock::now() - t0).count();
    Run out;
    out.allocs = bench::stop_counting_this_thread();
    out.frames = rounds * batch.size();
    out.ns_per_frame = s * 1e9 / static_cast<double>(out.frames);
    out.cpu_ns_per_frame = (thread_cpu_s() - cpu0) * 1e9 / static_cast<double>(out.frames);
    out.delivered = sink.delivered;
    out.ring_drops = rx->stats().ring_drops - drops0;
    return out;
  }
};

// The daemon's status source, reduced: the fixture's 4 x 32 devices with the
// hot path's latest values read through LastValues (as the daemon's status()).
web::WebServer::StatusSource status_source(const pipeline::LastValues& last) {
  return [&last] {
    control::StatusReport r = web::test::sample_report(kBuses, kDevices);
    for (std::size_t b = 0; b < r.buses.size(); ++b)
      for (auto& d : r.buses[b].devices) {
        const pipeline::LastValue v = last.read(b, d.node_id);
        if (v.value_wall_ns != 0) d.values.position = v.position;
      }
    return r;
  };
}

void print_run(const char* what, const HotPath::Run& r) {
  std::printf("  hot path %-26s: %7.1f ns/frame wall, %6.1f ns/frame CPU, %llu allocations on the hot-path thread in %zu frames, "
              "delivered %zu, ring drops %zu\n",
              what, r.ns_per_frame, r.cpu_ns_per_frame, r.allocs, r.frames, r.delivered, r.ring_drops);
}

void print_latency(const char* load, const std::string& path, const Latency& l) {
  std::printf("  %-10s %-15s p50 %6.2f ms  p99 %6.2f ms  max %6.2f ms  failed %zu\n", load, path.c_str(), l.p50_ms,
              l.p99_ms, l.max_ms, l.failed);
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t frames = 4'000'000;
  int clients = 50;
  int requests = 400;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--frames" && i + 1 < argc) frames = std::strtoull(argv[++i], nullptr, 10);
    else if (a == "--clients" && i + 1 < argc) clients = std::atoi(argv[++i]);
    else if (a == "--requests" && i + 1 < argc) requests = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: %s [--frames N] [--clients N] [--requests N]\n", argv[0]);
      return 2;
    }
  }
  HotPath hot;
  hot.run(64 * 200);  // warm-up: first touches
  const long rss_before = status_kib("VmRSS");
  std::printf("web bench: %d buses x %d devices, %d hammering clients on /metrics\n", kBuses, kDevices, clients);
  const HotPath::Run alone = hot.run(frames);

  web::WebServer server(status_source(hot.last));
  config::WebSettings settings;
  settings.port = 0;
  settings.max_clients = static_cast<std::uint32_t>(clients + 16);
  if (const cobridge::Error e = server.start(settings)) {
    std::fprintf(stderr, "web server: %s\n", e.to_string().c_str());
    return 1;
  }
  const std::uint16_t port = server.port();
  const std::vector<std::string> paths = {"/", "/api/v1/status", "/metrics"};
  std::vector<Latency> idle;
  for (const auto& p : paths) idle.push_back(measure(port, p, requests));
  const long rss_served = status_kib("VmRSS");

  std::atomic<bool> stop{false};
  std::atomic<std::size_t> served{0}, refused{0};
  std::vector<std::thread> hammer;
  for (int c = 0; c < clients; ++c)
    hammer.emplace_back([&] {
      while (!stop.load(std::memory_order_relaxed)) (http_get(port, "/metrics") ? served : refused)++;
    });
  const HotPath::Run beside = hot.run(frames);
  std::vector<Latency> loaded;
  for (const auto& p : paths) loaded.push_back(measure(port, p, requests));
  stop = true;
  for (auto& t : hammer) t.join();
  server.stop();

  print_run("alone", alone);
  print_run("beside the hammered web", beside);
  // CPU time is the hot path's own cost; wall time also counts the time the
  // scheduler gave the server and the clients on the same cores.
  std::printf("  hot path ratio (beside / alone)   : CPU %.2f, wall %.2f (%d clients + server share the cores)\n",
              beside.cpu_ns_per_frame / alone.cpu_ns_per_frame, beside.ns_per_frame / alone.ns_per_frame, clients);
  for (std::size_t i = 0; i < paths.size(); ++i) print_latency("idle", paths[i], idle[i]);
  for (std::size_t i = 0; i < paths.size(); ++i) print_latency("hammered", paths[i], loaded[i]);
  std::printf("  hammering clients: %zu answers, %zu failed or refused\n", served.load(), refused.load());
  std::printf("  RSS: %ld KiB before the web service, %ld KiB after serving (+%ld KiB); "
              "peak %ld KiB with %d client threads\n",
              rss_before, rss_served, rss_served - rss_before, status_kib("VmHWM"), clients);
  const bool clean = alone.allocs == 0 && beside.allocs == 0 && beside.ring_drops == 0 &&
                     beside.delivered == beside.frames;
  return clean ? 0 : 1;
}
