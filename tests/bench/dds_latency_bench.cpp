// DDS latency bench (prints figures; not a test). Targets: latency
// from a sample's receive timestamp to a DDS subscriber on the same host,
// p99 <= 200 us, at 36 000 samples/s (four saturated 1 Mbit/s buses, 32
// devices); 0 heap allocations per sample on the hot path.
//
// The process forks before any DDS entity exists: the child is the
// subscriber (its own Cyclone instance, so samples cross the loopback
// network as they would to a cell controller), the parent the gateway side.
//  1. Bare Cyclone ping-pong: the parent writes a sample on BenchPing, the
//     child echoes it on BenchPong; round trip on the parent's clock. Ping
//     and pong use domain D + 1, so that the plugin creates domain D itself
//     (its write_batch option needs that).
//  2. The plugin: libcobridge_dds.so loaded through pipeline::PluginHost and
//     fed TPDO samples at the target rate; the child computes receive time
//     minus rx_timestamp_ns per EncoderSample. Two feeds:
//       burst  - every 500 us a batch of rate/2000 samples, all with the
//                batch's time as rx_timestamp (the worst case for a queue);
//       spread - one sample every 1/rate s (four saturated buses: a frame
//                every ~111 us on each, ~28 us apart interleaved), each
//                with its nominal arrival time as rx_timestamp; the feeder
//                delivers whatever is due as soon as it wakes, as the
//                dispatcher does when a ring has data. Its own lateness
//                counts against the figure, like the real RX wake-up.
//     Each with best-effort and reliable samples, write_batch on and off;
//     then once more on a topic nobody reads, for the allocations alone.
//     Also printed: heap allocations per sample in the whole process while
//     feeding (plugin, writer thread, Cyclone), and the time on_samples
//     takes per sample on the feeding (dispatcher) thread.
//  2b. The floor of the spread feed: the same traffic written by a plain
//     thread with one dds_write per sample (no plugin, queue or hop), once
//     best-effort and once reliable (keep-last 1, the plugin's QoS), in the
//     same process layout as the plugin runs.
//  2c. A summary that sets each spread run of the plugin against
//     the bare stream of the same reliability from the same run of the
//     bench: p50/p99/p99.9 and the ratio plugin / bare (target p99 <= 1.2x).
//     Runs with EncoderSample written on the dispatcher (the feeding thread
//     here; sample_path "auto", the default) and on the plugin's writer
//     thread ("writer-thread").
//  3. The wake-up hop: atomic notify -> waiting thread running, the
//     mechanism by which the dispatcher wakes the plugin's writer thread.
//
// Usage: cobridge_bench_dds_latency [seconds per run = 5] [rate = 36000]
//                                   [feed = both|burst|spread]
//                                   [placement = shared|pinned]
// pinned: the subscriber on the last CPU, the gateway side on CPU 0.
// CYCLONEDDS_URI, if unset, is pinned to the loopback interface.
#include "bench_devices.hpp"
#include "bench_time.hpp"
#include "alloc_counter.hpp"
#include "pipeline/plugin_host.hpp"
#include "pipeline/sample.hpp"

#include "cobridge_idl/cobridge.h"

#include <dds/dds.h>
#include <dds/version.h>
#include <sched.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>


using namespace cobridge;

namespace {

using namespace cobridge::bench;  // bench_time.hpp: clocks and percentiles

constexpr std::uint32_t kStop = 0xFFFFFFFFu;  // sequence_number of the ping that ends the child
constexpr std::size_t kTake = 256;


double ratio(std::uint64_t a, std::uint64_t b) { return b != 0 ? static_cast<double>(a) / static_cast<double>(b) : 0.0; }
void print(const char* what, const Figures& f) {
  std::printf("  %-44s n=%-8" PRIu64 " p50=%7.1f us  p99=%7.1f us  p99.9=%7.1f us  max=%8.1f us\n", what, f.count,
              static_cast<double>(f.p50) / 1e3, static_cast<double>(f.p99) / 1e3, static_cast<double>(f.p999) / 1e3,
              static_cast<double>(f.max) / 1e3);
}

dds_qos_t* qos(dds_reliability_kind_t rel, dds_history_kind_t hist, int32_t depth) {
  dds_qos_t* q = dds_create_qos();
  dds_qset_reliability(q, rel, DDS_SECS(1));
  dds_qset_history(q, hist, depth);
  return q;
}

// --- the subscriber process -------------------------------------------------

// Runs until the stop ping; writes per-run latencies (ns) to `out_fd`:
// a count, then the values, once per run (a run ends with a stop ping whose
// position is the run number; position -1 ends the process).
int subscriber(std::uint32_t domain, int out_fd) {
  const dds_entity_t pp = dds_create_participant(domain, nullptr, nullptr);
  const dds_entity_t pp_ping = dds_create_participant(domain + 1, nullptr, nullptr);
  if (pp < 0 || pp_ping < 0) return 1;
  const dds_entity_t t_sample = dds_create_topic(pp, &cobridge_EncoderSample_desc, "EncoderSample", nullptr, nullptr);
  const dds_entity_t t_ping = dds_create_topic(pp_ping, &cobridge_EncoderSample_desc, "BenchPing", nullptr, nullptr);
  const dds_entity_t t_pong = dds_create_topic(pp_ping, &cobridge_EncoderSample_desc, "BenchPong", nullptr, nullptr);
  // Best-effort readers match both writer kinds; deep enough never to drop.
  dds_qos_t* rq = qos(DDS_RELIABILITY_BEST_EFFORT, DDS_HISTORY_KEEP_LAST, 4096);
  const dds_entity_t r_sample = dds_create_reader(pp, t_sample, rq, nullptr);
  dds_delete_qos(rq);
  dds_qos_t* pq = qos(DDS_RELIABILITY_RELIABLE, DDS_HISTORY_KEEP_ALL, 0);
  const dds_entity_t r_ping = dds_create_reader(pp_ping, t_ping, pq, nullptr);
  const dds_entity_t w_pong = dds_create_writer(pp_ping, t_pong, pq, nullptr);
  dds_delete_qos(pq);
  const dds_entity_t ws = dds_create_waitset(DDS_CYCLONEDDS_HANDLE);  // readers of two domains
  dds_waitset_attach(ws, dds_create_readcondition(r_sample, DDS_ANY_STATE), 1);
  dds_waitset_attach(ws, dds_create_readcondition(r_ping, DDS_ANY_STATE), 2);

  std::vector<std::uint64_t> lat;
  lat.reserve(1u << 20);
  void* buf[kTake];
  dds_sample_info_t info[kTake];
  bool running = true;
  while (running) {
    dds_attach_t trig[2];
    dds_waitset_wait(ws, trig, 2, DDS_SECS(1));
    buf[0] = nullptr;
    int n = dds_take(r_sample, buf, info, kTake, kTake);
    const std::uint64_t now = realtime_ns();
    for (int i = 0; i < n; ++i) {
      const auto idx = static_cast<std::size_t>(i);
      if (!info[idx].valid_data) continue;
      const auto* s = static_cast<const cobridge_EncoderSample*>(buf[idx]);
      // Pairs: from the receive timestamp, and from the hand-over to the
      // plugin (publish_timestamp_ns), which leaves out the feeder's delay.
      lat.push_back(now > s->rx_timestamp_ns ? now - s->rx_timestamp_ns : 0);
      lat.push_back(now > s->publish_timestamp_ns ? now - s->publish_timestamp_ns : 0);
    }
    if (n > 0) dds_return_loan(r_sample, buf, n);
    buf[0] = nullptr;
    n = dds_take(r_ping, buf, info, kTake, kTake);
    for (int i = 0; i < n; ++i) {
      const auto idx = static_cast<std::size_t>(i);
      if (!info[idx].valid_data) continue;
      const auto* s = static_cast<const cobridge_EncoderSample*>(buf[idx]);
      if (s->sequence_number == kStop) {
        const std::uint64_t count = lat.size();
        if (write(out_fd, &count, sizeof count) != sizeof count) return 1;
        const auto bytes = static_cast<ssize_t>(count * sizeof(std::uint64_t));
        if (count != 0 && write(out_fd, lat.data(), static_cast<std::size_t>(bytes)) != bytes) return 1;
        lat.clear();
        if (s->position < 0) running = false;
      }
      dds_write(w_pong, s);  // echo (the stop ping too: the parent waits for it)
    }
    if (n > 0) dds_return_loan(r_ping, buf, n);
  }
  dds_delete(ws);
  dds_delete(pp);
  dds_delete(pp_ping);
  return 0;
}

// --- the gateway side -------------------------------------------------------

struct PingSide {
  dds_entity_t pp = 0, w_ping = 0, r_pong = 0, ws = 0;
  explicit PingSide(std::uint32_t domain) {
    pp = dds_create_participant(domain + 1, nullptr, nullptr);
    const dds_entity_t t_ping = dds_create_topic(pp, &cobridge_EncoderSample_desc, "BenchPing", nullptr, nullptr);
    const dds_entity_t t_pong = dds_create_topic(pp, &cobridge_EncoderSample_desc, "BenchPong", nullptr, nullptr);
    dds_qos_t* q = qos(DDS_RELIABILITY_RELIABLE, DDS_HISTORY_KEEP_ALL, 0);
    w_ping = dds_create_writer(pp, t_ping, q, nullptr);
    r_pong = dds_create_reader(pp, t_pong, q, nullptr);
    dds_delete_qos(q);
    ws = dds_create_waitset(pp);
    dds_waitset_attach(ws, dds_create_readcondition(r_pong, DDS_ANY_STATE), 0);
  }
  ~PingSide() { dds_delete(pp); }
  // One round trip; 0 on timeout.
  std::uint64_t ping(std::uint32_t seq, std::int64_t position = 0) {
    cobridge_EncoderSample s{};
    s.gateway_id = const_cast<char*>("bench");
    s.device_name = const_cast<char*>("");
    s.sequence_number = seq;
    s.position = position;
    const std::uint64_t t0 = mono_ns();
    dds_write(w_ping, &s);
    for (;;) {
      dds_attach_t trig;
      if (dds_waitset_wait(ws, &trig, 1, DDS_SECS(2)) <= 0) return 0;
      void* buf[kTake] = {};
      dds_sample_info_t info[kTake];
      const int n = dds_take(r_pong, buf, info, kTake, kTake);
      bool mine = false;
      for (int i = 0; i < n; ++i) {
        const auto idx = static_cast<std::size_t>(i);
        if (info[idx].valid_data && static_cast<const cobridge_EncoderSample*>(buf[idx])->sequence_number == seq) mine = true;
      }
      if (n > 0) dds_return_loan(r_pong, buf, n);
      if (mine) return mono_ns() - t0;
    }
  }
  bool wait_matched() {
    for (int i = 0; i < 500; ++i) {
      dds_publication_matched_status_t st{};
      dds_get_publication_matched_status(w_ping, &st);
      if (st.current_count > 0 && ping(0x7FFFFFF0u) != 0) return true;
      usleep(10000);
    }
    return false;
  }
};

std::vector<std::uint64_t> read_run(int fd) {
  std::uint64_t count = 0;
  if (read(fd, &count, sizeof count) != sizeof count) return {};
  std::vector<std::uint64_t> v(count);
  auto* p = reinterpret_cast<char*>(v.data());
  std::size_t left = count * sizeof(std::uint64_t);
  while (left > 0) {
    const ssize_t n = read(fd, p, left);
    if (n <= 0) break;
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  return v;
}

enum class Feed { kBurst, kSpread };

// 32 devices: 8 per bus on 4 buses; samples round-robin over them.
constexpr unsigned kDevices = 32;

struct Feeder {
  std::uint32_t seq[kDevices] = {};
  unsigned next_device = 0;
  void fill(pipeline::Sample& s, std::uint64_t rx_ns) {
    s = pipeline::Sample{};
    const unsigned d = next_device;
    next_device = (next_device + 1) % kDevices;
    s.kind = COBRIDGE_SAMPLE_TPDO;
    s.device_index = static_cast<std::uint16_t>(d);
    s.bus_index = static_cast<std::uint8_t>(d / 8);
    s.node_id = static_cast<std::uint8_t>(1 + d % 8);
    s.sequence = ++seq[d];
    s.rx_timestamp_ns = rx_ns;
    s.publish_timestamp_ns = realtime_ns();
    s.position = static_cast<std::int64_t>(s.sequence);
    s.valid = COBRIDGE_VALID_POSITION | COBRIDGE_VALID_SPEED;
  }
};


// The spread feed's clock: sample k is due at start + k / rate and carries
// the receive time real0 + k / rate. On each wake-up, take(first, n, rx_ns)
// gets the samples due by then (at most max_batch); then it sleeps until the
// next one is due.
template <typename Take>
void spread_feed(std::uint64_t total, unsigned rate, std::size_t max_batch, Take take) {
  const std::uint64_t mono0 = mono_ns() + 1000000, real0 = realtime_ns() + 1000000;
  const auto due_at = [rate](std::uint64_t k) { return k * 1000000000ull / rate; };
  const auto rx_ns = [&](std::uint64_t k) { return real0 + due_at(k); };
  sleep_until_mono(mono0);
  std::uint64_t k = 0;
  while (k < total) {
    const std::uint64_t elapsed = mono_ns() - mono0;
    std::size_t n = 0;
    while (k + n < total && n < max_batch && due_at(k + n) <= elapsed) ++n;
    if (n == 0) {
      sleep_until_mono(mono0 + due_at(k));
      continue;
    }
    take(k, n, rx_ns);
    k += n;
  }
}

// One run of the plugin at `rate` samples/s for `seconds`.
Figures plugin_run(const char* label, Feed feed, const std::string& config, double seconds, unsigned rate,
                   PingSide& ping, int from_child, std::uint32_t run) {
  const std::filesystem::path plugin = COBRIDGE_DDS_PLUGIN_FILE;
  pipeline::PluginHost host({plugin.parent_path(), "bench-gw",
                             [](pipeline::LogLevel, std::string_view, std::string_view m) {
                               std::fprintf(stderr, "  plugin: %.*s\n", static_cast<int>(m.size()), m.data());
                             }});
  if (const Error err = host.load({"dds", "dds", plugin, config})) {
    std::fprintf(stderr, "load failed: %s\n", err.message.c_str());
    return {};
  }
  if (!host.start_all().empty()) return {};
  announce_devices(host, kDevices, [](unsigned d) { return "axis " + std::to_string(d); });
  usleep(500000);  // let discovery of the plugin's writers settle

  Feeder feeder;
  std::vector<pipeline::Sample> batch(256);
  std::vector<std::uint64_t> write_cost;
  write_cost.reserve(static_cast<std::size_t>(seconds * rate) + 16);
  std::uint64_t sent = 0, delivers = 0;
  auto deliver = [&](std::size_t n) {
    const std::uint64_t t0 = mono_ns();
    host.deliver(std::span<const pipeline::Sample>(batch.data(), n));
    write_cost.push_back((mono_ns() - t0) / n);
    sent += n;
    ++delivers;
  };
  const auto total = static_cast<std::uint64_t>(seconds * rate);
  bench::start_counting_allocations();
  if (feed == Feed::kBurst) {
    // Every 500 us the samples of 500 us, one timestamp.
    constexpr std::uint64_t kPeriodNs = 500000;
    const auto per_batch = static_cast<std::size_t>(
        std::clamp<std::uint64_t>(static_cast<std::uint64_t>(rate) * kPeriodNs / 1000000000ull, 1, batch.size()));
    std::uint64_t next = mono_ns();
    while (sent + per_batch <= total) {
      const std::uint64_t now = realtime_ns();
      for (std::size_t i = 0; i < per_batch; ++i) feeder.fill(batch[i], now);
      deliver(per_batch);
      next += kPeriodNs;
      sleep_until_mono(next);
    }
  } else {
    // Deliver what is due on waking.
    spread_feed(total, rate, batch.size(), [&](std::uint64_t first, std::size_t n, auto rx_ns) {
      for (std::size_t i = 0; i < n; ++i) feeder.fill(batch[i], rx_ns(first + i));
      deliver(n);
    });
  }
  usleep(200000);  // in-flight samples
  const unsigned long long allocs = bench::stop_counting_allocations();
  host.stop_all();
  ping.ping(kStop, static_cast<std::int64_t>(run));
  const std::vector<std::uint64_t> pairs = read_run(from_child);
  std::vector<std::uint64_t> lat, from_deliver;
  lat.reserve(pairs.size() / 2);
  from_deliver.reserve(pairs.size() / 2);
  for (std::size_t i = 0; i + 1 < pairs.size(); i += 2) {
    lat.push_back(pairs[i]);
    from_deliver.push_back(pairs[i + 1]);
  }
  std::printf("%s: %u samples/s for %.1f s, %" PRIu64 " sent in %" PRIu64 " deliveries, %zu received (%.3f%% lost)\n",
              label, rate, seconds, sent, delivers, lat.size(),
              sent != 0 ? 100.0 * (1.0 - static_cast<double>(lat.size()) / static_cast<double>(sent)) : 0.0);
  const Figures result = figures(lat);
  print("rx_timestamp -> subscriber", result);
  print("  of which on_samples -> subscriber", figures(from_deliver));
  print("on_samples cost per sample (dispatcher)", figures(write_cost));
  std::printf("  heap allocations in the process: %llu = %.2f per sample\n", allocs,
              sent != 0 ? static_cast<double>(allocs) / static_cast<double>(sent) : 0.0);
  return result;
}

// The floor for the same traffic: a plain thread writes EncoderSample with
// dds_write at the spread feed's pace (no plugin, no queue, no wake-up hop),
// best-effort, to the same subscriber.
Figures bare_stream_run(std::uint32_t domain, double seconds, unsigned rate, PingSide& ping, int from_child,
                        std::uint32_t run, bool reliable) {
  const dds_entity_t pp = dds_create_participant(domain, nullptr, nullptr);
  const dds_entity_t topic = dds_create_topic(pp, &cobridge_EncoderSample_desc, "EncoderSample", nullptr, nullptr);
  dds_qos_t* q = qos(reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT, DDS_HISTORY_KEEP_LAST, 1);
  const dds_entity_t writer = dds_create_writer(pp, topic, q, nullptr);
  dds_delete_qos(q);
  if (pp < 0 || topic < 0 || writer < 0) {
    std::fprintf(stderr, "bare stream: cannot create the writer\n");
    return {};
  }
  usleep(500000);  // discovery
  Feeder feeder;
  pipeline::Sample s{};
  const auto total = static_cast<std::uint64_t>(seconds * rate);
  spread_feed(total, rate, 1, [&](std::uint64_t first, std::size_t, auto rx_ns) {
    feeder.fill(s, rx_ns(first));
    cobridge_EncoderSample m{};
    m.gateway_key = 1;
    m.gateway_id = const_cast<char*>("bench-gw");
    m.device_name = const_cast<char*>("");
    m.bus = s.bus_index;
    m.node_id = s.node_id;
    m.position = s.position;
    m.rx_timestamp_ns = s.rx_timestamp_ns;
    m.publish_timestamp_ns = realtime_ns();
    m.sequence_number = s.sequence;
    (void)dds_write(writer, &m);
  });
  usleep(200000);
  dds_delete(pp);
  ping.ping(kStop, static_cast<std::int64_t>(run));
  const std::vector<std::uint64_t> pairs = read_run(from_child);
  std::vector<std::uint64_t> lat;
  for (std::size_t i = 0; i + 1 < pairs.size(); i += 2) lat.push_back(pairs[i]);
  std::printf("bare Cyclone stream (one dds_write per sample, spread, %s): %u samples/s for %.1f s, %" PRIu64
              " sent, %zu received\n",
              reliable ? "reliable" : "best-effort", rate, seconds, total, lat.size());
  const Figures result = figures(lat);
  print("rx_timestamp -> subscriber", result);
  return result;
}

// 2c: one line per plugin run against the bare stream of its reliability.
void print_against(const char* label, const Figures& plugin, const Figures& bare) {
  std::printf("  %-46s p50=%7.1f p99=%7.1f p99.9=%7.1f us | bare p50=%7.1f p99=%7.1f p99.9=%7.1f us | "
              "ratio p50 %.2f p99 %.2f p99.9 %.2f\n",
              label, static_cast<double>(plugin.p50) / 1e3, static_cast<double>(plugin.p99) / 1e3,
              static_cast<double>(plugin.p999) / 1e3, static_cast<double>(bare.p50) / 1e3,
              static_cast<double>(bare.p99) / 1e3, static_cast<double>(bare.p999) / 1e3, ratio(plugin.p50, bare.p50),
              ratio(plugin.p99, bare.p99), ratio(plugin.p999, bare.p999));
}

// The wake-up hop: one thread bumps an atomic and notifies, the other waits
// on it (as Instance::wake / Instance::run in the plugin); latency from the
// notify to the waiter running, every 500 us.
void wake_run(unsigned count) {
  std::atomic<std::uint32_t> word{0};
  std::atomic<std::uint64_t> sent_at{0};
  std::atomic<bool> done{false};
  std::vector<std::uint64_t> lat;
  lat.reserve(count);
  std::thread waiter([&] {
    std::uint32_t seen = 0;
    while (!done.load(std::memory_order_acquire)) {
      word.wait(seen, std::memory_order_acquire);
      seen = word.load(std::memory_order_acquire);
      const std::uint64_t now = mono_ns();
      if (!done.load(std::memory_order_acquire)) lat.push_back(now - sent_at.load(std::memory_order_acquire));
    }
  });
  std::uint64_t next = mono_ns();
  for (unsigned i = 0; i < count; ++i) {
    next += 500000;
    sleep_until_mono(next);
    sent_at.store(mono_ns(), std::memory_order_release);
    word.fetch_add(1, std::memory_order_release);
    word.notify_one();
  }
  usleep(2000);
  done.store(true, std::memory_order_release);
  word.fetch_add(1, std::memory_order_release);
  word.notify_one();
  waiter.join();
  std::printf("writer wake-up hop (atomic notify -> waiting thread runs, every 500 us):\n");
  print("notify -> running", figures(lat));
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 5.0;
  const unsigned rate = argc > 2 ? static_cast<unsigned>(std::atoi(argv[2])) : 36000u;
  const std::string feeds = argc > 3 ? argv[3] : "both";
  const std::string placement = argc > 4 ? argv[4] : "shared";
  if (seconds <= 0 || rate == 0 || (feeds != "both" && feeds != "burst" && feeds != "spread") ||
      (placement != "shared" && placement != "pinned")) {
    std::fprintf(stderr, "usage: %s [seconds > 0] [rate > 0] [both|burst|spread] [shared|pinned]\n", argv[0]);
    return 2;
  }
  // pinned: the gateway side on CPU 0, the subscriber on the last CPU, as a
  // gateway with the cell controller's reader elsewhere would be.
  const long cpus = sysconf(_SC_NPROCESSORS_ONLN);
  const auto pin = [](long cpu) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(static_cast<std::size_t>(cpu), &set);
    return sched_setaffinity(0, sizeof set, &set) == 0;
  };
  const bool pinned = placement == "pinned" && cpus >= 2;
  setvbuf(stdout, nullptr, _IOLBF, 0);  // lines stay whole next to the plugin's log on stderr
  setenv("CYCLONEDDS_URI", "<General><Interfaces><NetworkInterface name=\"lo\" multicast=\"true\"/></Interfaces></General>", 0);
  // The feeder stands in for the dispatcher, which futex wake-ups (not
  // timers) drive: without this, timer slack (50 us) would delay it.
  prctl(PR_SET_TIMERSLACK, 1000UL, 0, 0, 0);
  const std::uint32_t domain = 150u + 2u * (static_cast<std::uint32_t>(getpid()) % 40u);  // and domain + 1

  int fds[2];
  if (pipe(fds) != 0) return 1;
  const pid_t child = fork();
  if (child == 0) {
    close(fds[0]);
    if (pinned && !pin(cpus - 1)) _exit(3);
    _exit(subscriber(domain, fds[1]));
  }
  close(fds[1]);
  if (pinned && !pin(0)) std::fprintf(stderr, "cannot pin the gateway side to CPU 0\n");

  std::printf("DDS latency bench: Cyclone DDS %s, domains %u/%u, subscriber in a separate process, host: %ld CPUs\n",
              DDS_VERSION, domain, domain + 1, sysconf(_SC_NPROCESSORS_ONLN));
  {
    PingSide ping(domain);
    if (!ping.wait_matched()) {
      std::fprintf(stderr, "subscriber not found\n");
      kill(child, SIGKILL);
      return 1;
    }
    std::vector<std::uint64_t> rtt;
    for (std::uint32_t i = 1; i <= 2000; ++i) {
      if (const std::uint64_t t = ping.ping(i); t != 0) rtt.push_back(t);
      usleep(500);
    }
    std::printf("bare Cyclone ping-pong (reliable, same type, loopback):\n");
    Figures f = figures(rtt);
    print("round trip", f);
    f.p50 /= 2;
    f.p99 /= 2;
    f.p999 /= 2;
    f.max /= 2;
    print("one way (round trip / 2)", f);
    wake_run(4000);

    const std::string d = "domain = " + std::to_string(domain) + "\n";
    struct Run {
      const char* label;
      Feed feed;
      std::string config;
      bool reliable = false;
    };
    // sample_path "auto" is the default (the dispatcher writes, a full
    // reliable history spills to the writer thread).
    const std::string wt = "sample_path = \"writer-thread\"\n", rel = "sample_reliability = \"reliable\"\n",
                      nob = "write_batch = false\n";
    std::vector<Run> runs;
    for (const Feed feed : {Feed::kSpread, Feed::kBurst}) {
      if (feeds != "both" && (feed == Feed::kSpread) != (feeds == "spread")) continue;
      const bool sp = feed == Feed::kSpread;
      runs.push_back({sp ? "spread, best-effort, auto (default), write_batch" : "burst, best-effort, auto (default), write_batch",
                      feed, d});
      runs.push_back({sp ? "spread, best-effort, auto, no batching" : "burst, best-effort, auto, no batching",
                      feed, d + nob});
      runs.push_back({sp ? "spread, best-effort, writer thread, write_batch"
                         : "burst, best-effort, writer thread, write_batch",
                      feed, d + wt});
      runs.push_back({sp ? "spread, reliable, auto (default), write_batch" : "burst, reliable, auto (default), write_batch",
                      feed, d + rel, true});
      runs.push_back({sp ? "spread, reliable, writer thread, write_batch" : "burst, reliable, writer thread, write_batch",
                      feed, d + rel + wt, true});
    }
    // Allocations with no reader matched: the subscriber does not read this
    // topic (its latency line stays empty).
    runs.push_back({"no reader matched (allocations only), burst, best-effort, write_batch", Feed::kBurst,
                     d + "topic_prefix = \"unread/\"\n"});
    std::uint32_t run = 0;
    Figures bare_be, bare_rel;
    if (feeds != "burst") {
      bare_be = bare_stream_run(domain, seconds, rate, ping, fds[0], ++run, false);
      bare_rel = bare_stream_run(domain, seconds, rate, ping, fds[0], ++run, true);
    }
    std::vector<std::pair<const Run*, Figures>> results;
    for (const Run& r : runs) results.emplace_back(&r, plugin_run(r.label, r.feed, r.config, seconds, rate, ping, fds[0], ++run));
    if (feeds != "burst") {
      std::printf("plugin against bare Cyclone, same run, same layout (%s), %u samples/s, spread feed:\n",
                  placement.c_str(), rate);
      for (const auto& [r, fig] : results) {
        if (r->feed == Feed::kSpread) print_against(r->label, fig, r->reliable ? bare_rel : bare_be);
      }
    }
    ping.ping(kStop, -1);
    (void)read_run(fds[0]);
  }
  int status = 0;
  waitpid(child, &status, 0);
  return 0;
}
