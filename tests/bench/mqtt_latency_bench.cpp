// MQTT (Sparkplug B) latency and loss bench (prints figures; not a test).
// Targets (docs/mqtt.md, performance): from a CAN sample's receive time to a
// subscriber's callback through a real broker on loopback, p99 <= 1.2x a
// bare libmosquitto publisher of the same payloads in the same run; 32
// devices at 1 kHz (32 000 samples/s) without loss; 0 heap allocations per
// sample on the feeding (dispatcher) thread with the plugin loaded.
//
// How:
//  - Broker: the bench writes a minimal mosquitto.conf (a loopback listener
//    on a free port, anonymous, no persistence, TCP_NODELAY so that Nagle's
//    algorithm does not blur the comparison) into a temporary directory and
//    starts Debian's mosquitto on it.
//  - Subscriber: a forked process with its own libmosquitto client on
//    spBv1.0/bench/# and its own reader of the Sparkplug payload: a few
//    lines of protobuf wire format rather than the plugin's protobuf-c code,
//    so an encoding mistake cannot cancel out in the decoder, and nothing is
//    allocated per message, so the subscriber costs the same for both
//    publishers.
//  - The stream: sample k of a run (k = 0 .. rate x seconds - 1) belongs to
//    device k mod 32, carries position k (every value unique) and speed k,
//    is due at start + k / rate, and its rx_timestamp_ns is that nominal
//    arrival time, real0 + k / rate. The parent sends real0 and the rate to
//    the subscriber, which takes CLOCK_REALTIME in its message callback,
//    finds the sample by its Position value and records now - its receive
//    time; it counts values missing, duplicated and out of order per device.
//  - plugin: libcobridge_mqtt.so through pipeline::PluginHost with an
//    [outputs.mqtt] table naming the bench's broker (no primary host), 32
//    devices announced (on_device; the run starts once the subscriber has
//    seen their 32 DBIRTHs), then the spread feed: on each wake-up the
//    feeding thread (standing in for the dispatcher) delivers every sample
//    due by then, so its own lateness counts against the figure as the real
//    RX wake-up would. Counted: heap allocations on the feeding thread (the
//    hot path's bound) and in the whole process; on_samples time per sample.
//  - bare: the same stream published by the feeding thread itself, one
//    mosquitto_publish per sample of a payload encoded before the run (the
//    fields the plugin sends: payload timestamp, Position and Speed by alias
//    with the receive time, seq) on the same topics, with a client in
//    threaded mode and TCP_NODELAY like the plugin's. The floor: no ring, no
//    publisher thread, no encoding.
//  The feeding thread's timer slack is
//  1 us (the dispatcher is woken by futexes, not timers); the plugin's and
//  libmosquitto's threads keep the default, as in the daemon.
//
// Each rate runs bare and plugin in alternating slices (5 by default, each
// a new client or a newly loaded plugin), so that a change in the rest of
// the host's load hits both alike; each publisher's figures pool its slices.
//
// Usage: cobridge_bench_mqtt_latency [seconds per publisher and rate = 10]
//                                    [rate,rate... = 32000,1000] [slices = 5]
// Lines starting "FIGURE mqtt" are what scripts/bench reads.
#include "bench_devices.hpp"
#include "bench_time.hpp"
#include "alloc_counter.hpp"
#include "pipeline/plugin_host.hpp"
#include "pipeline/sample.hpp"

#include <mosquitto.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <mutex>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

using namespace cobridge;

namespace {

using namespace cobridge::bench;  // bench_time.hpp: clocks and percentiles

constexpr unsigned kDevices = 32;
constexpr const char* kGroup = "bench";
constexpr const char* kEdge = "bench-gw";
// docs/mqtt.md, metric table: ids of Position (Int64) and Speed (Int32).
constexpr std::uint64_t kPositionId = 1, kSpeedId = 3;
constexpr std::uint32_t kInt32 = 3, kInt64 = 4;  // Sparkplug datatypes (spec 6.4.16)


double us(std::uint64_t ns) { return static_cast<double>(ns) / 1e3; }
void print(const char* what, const Figures& f) {
  std::printf("  %-42s n=%-8" PRIu64 " p50=%8.1f us  p99=%8.1f us  p99.9=%8.1f us  max=%9.1f us\n", what, f.count,
              us(f.p50), us(f.p99), us(f.p999), us(f.max));
}

// --- the Sparkplug payload, by hand (protobuf wire format) -------------------

std::uint64_t alias_of(unsigned device, std::uint64_t id) { return (device + 1u) * 256u + id; }
std::string device_name(unsigned d) { return "axis" + std::to_string(d); }
std::string ddata_topic(unsigned d) {
  return std::string("spBv1.0/") + kGroup + "/DDATA/" + kEdge + "/" + device_name(d);
}

void put_varint(std::vector<std::uint8_t>& out, std::uint64_t v) {
  for (; v >= 0x80; v >>= 7) out.push_back(static_cast<std::uint8_t>(v | 0x80));
  out.push_back(static_cast<std::uint8_t>(v));
}

// One Metric by alias (spec 6.4.4): alias (2), timestamp (3), datatype (4),
// the value in int_value (10) or long_value (11); the order protobuf-c packs.
void put_metric(std::vector<std::uint8_t>& out, std::uint64_t alias, std::uint64_t ts_ms, std::uint32_t type,
                std::uint64_t value) {
  std::vector<std::uint8_t> m;
  m.push_back(0x10);
  put_varint(m, alias);
  m.push_back(0x18);
  put_varint(m, ts_ms);
  m.push_back(0x20);
  put_varint(m, type);
  m.push_back(type == kInt64 ? 0x58 : 0x50);
  put_varint(m, value);
  out.push_back(0x12);  // Payload.metrics (2)
  put_varint(out, m.size());
  out.insert(out.end(), m.begin(), m.end());
}

// The DDATA of sample k as the plugin builds it: timestamp (1), Position and
// Speed (2), seq (3).
void put_ddata(std::vector<std::uint8_t>& out, std::uint64_t k, std::uint64_t ts_ms, std::uint8_t seq) {
  const auto d = static_cast<unsigned>(k % kDevices);
  out.push_back(0x08);
  put_varint(out, ts_ms);
  put_metric(out, alias_of(d, kPositionId), ts_ms, kInt64, k);
  put_metric(out, alias_of(d, kSpeedId), ts_ms, kInt32, k & 0x7FFFFFFFu);  // Int32: two's complement, uint32
  out.push_back(0x18);
  put_varint(out, seq);
}

struct WireReader {
  const std::uint8_t* p;
  const std::uint8_t* end;
  bool varint(std::uint64_t& v) {
    v = 0;
    for (unsigned shift = 0; p < end && shift < 64; shift += 7) {
      const std::uint8_t b = *p++;
      v |= static_cast<std::uint64_t>(b & 0x7Fu) << shift;
      if ((b & 0x80u) == 0) return true;
    }
    return false;
  }
  // Steps over one field of wire type `wt`; false on malformed input.
  bool skip(std::uint64_t wt) {
    std::uint64_t n = 0;
    if (wt == 0) return varint(n);
    if (wt == 1) n = 8;
    else if (wt == 5) n = 4;
    else if (wt != 2 || !varint(n)) return false;
    if (n > static_cast<std::uint64_t>(end - p)) return false;
    p += n;
    return true;
  }
};

// A Metric's alias and long_value, when it is a device's Position.
bool position_of(WireReader m, unsigned& device, std::uint64_t& value) {
  std::uint64_t alias = 0, key = 0;
  bool has_value = false;
  while (m.p < m.end) {
    if (!m.varint(key)) return false;
    if (key == 0x10) {
      if (!m.varint(alias)) return false;
    } else if (key == 0x58) {
      if (!m.varint(value)) return false;
      has_value = true;
    } else if (!m.skip(key & 7u)) {
      return false;
    }
  }
  if (!has_value || alias < 256 || alias % 256 != kPositionId) return false;
  device = static_cast<unsigned>(alias / 256 - 1);
  return true;
}

// Every Position metric of a DDATA payload (one per sample; a batched
// DDATA holds several): its device (from the alias) and value, to `each`.
// Returns how many; -1 for a payload that does not parse.
template <typename Each>
int for_each_position(const std::uint8_t* data, std::size_t len, Each&& each) {
  WireReader r{data, data + len};
  std::uint64_t key = 0, n = 0;
  int found = 0;
  while (r.p < r.end) {
    if (!r.varint(key)) return -1;
    if (key != 0x12) {
      if (!r.skip(key & 7u)) return -1;
      continue;
    }
    if (!r.varint(n) || n > static_cast<std::uint64_t>(r.end - r.p)) return -1;
    const WireReader metric{r.p, r.p + n};
    r.p += n;
    unsigned device = 0;
    std::uint64_t value = 0;
    if (position_of(metric, device, value)) {
      each(device, value);
      ++found;
    }
  }
  return found;
}

// CPU time (user + system) a process has used, in s (/proc/<pid>/stat
// fields 14 and 15): who is busy when a stream falls behind.
double cpu_seconds(const std::filesystem::path& stat_file) {
  std::ifstream f(stat_file);
  const std::string stat((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const std::size_t paren = stat.rfind(')');  // the command name may hold spaces
  if (paren == std::string::npos) return 0.0;
  std::istringstream in(stat.substr(paren + 1));
  std::string field;
  for (int i = 3; i < 14; ++i) in >> field;
  unsigned long long user = 0, system = 0;
  in >> user >> system;
  return static_cast<double>(user + system) / static_cast<double>(sysconf(_SC_CLK_TCK));
}
double cpu_seconds(pid_t pid) { return cpu_seconds("/proc/" + std::to_string(pid) + "/stat"); }

// Adds the CPU time of each thread of this process but the main (feeding)
// one to `sum`, by thread name. They all start with a slice's publisher, so
// their totals are the slice's: which one was saturated, if any.
void add_thread_cpu(std::vector<std::pair<std::string, double>>& sum) {
  const std::string main_tid = std::to_string(getpid());
  std::error_code ec;
  for (const auto& task : std::filesystem::directory_iterator("/proc/self/task", ec)) {
    if (task.path().filename() == main_tid) continue;
    std::string name;
    std::getline(std::ifstream(task.path() / "comm"), name);
    const double cpu = cpu_seconds(task.path() / "stat");
    auto it = std::find_if(sum.begin(), sum.end(), [&](const auto& s) { return s.first == name; });
    if (it == sum.end()) it = sum.insert(sum.end(), {name, 0.0});
    it->second += cpu;
  }
}

// --- the broker ---------------------------------------------------------------

std::uint16_t free_loopback_port() {
  const int s = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  std::uint16_t port = 0;
  if (s >= 0 && bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
      getsockname(s, reinterpret_cast<sockaddr*>(&a), &len) == 0)
    port = ntohs(a.sin_port);
  if (s >= 0) close(s);
  return port;
}

bool port_accepts(std::uint16_t port) {
  const int s = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(port);
  const bool ok = s >= 0 && connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  if (s >= 0) close(s);
  return ok;
}

// Debian's mosquitto on a loopback port, with a configuration of our own.
struct Broker {
  pid_t pid = -1;
  std::uint16_t port = 0;
  std::filesystem::path dir;

  bool start() {
    char tmpl[] = "/tmp/cobridge-mqtt-bench-XXXXXX";
    if (mkdtemp(tmpl) == nullptr) return false;
    dir = tmpl;
    port = free_loopback_port();
    const std::string conf = (dir / "mosquitto.conf").string();
    std::ofstream(conf) << "listener " << port << " 127.0.0.1\nallow_anonymous true\npersistence false\n"
                        << "set_tcp_nodelay true\nlog_dest stderr\nlog_type error\nlog_type warning\n";
    pid = fork();
    if (pid == 0) {
      prctl(PR_SET_PDEATHSIG, SIGTERM);  // never outlives the bench
      execl(COBRIDGE_MOSQUITTO_BROKER, "mosquitto", "-c", conf.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    for (int i = 0; pid > 0 && i < 500; ++i) {
      if (port_accepts(port)) return true;
      if (waitpid(pid, nullptr, WNOHANG) == pid) pid = -1;
      usleep(10000);
    }
    return false;
  }
  ~Broker() {
    if (pid > 0) {
      kill(pid, SIGTERM);
      waitpid(pid, nullptr, 0);
    }
    std::error_code ec;
    if (!dir.empty()) std::filesystem::remove_all(dir, ec);
  }
};

// --- parent <-> subscriber (pipes) ---------------------------------------------

enum class OrderKind : std::uint32_t { kArm, kGo, kTally, kEnd, kQuit };
struct Order {
  OrderKind kind = OrderKind::kTally;
  std::uint32_t pad = 0;
  std::uint64_t real0_ns = 0, rate = 0, total = 0;
};
// What the subscriber counted in a run (births: DBIRTHs since kArm;
// span_ns: from the first sample's receive stamp to the last arrival).
struct Tally {
  std::uint64_t received = 0, duplicates = 0, out_of_order = 0, births = 0, other = 0, ddata_bytes = 0, span_ns = 0;
};

bool write_all(int fd, const void* data, std::size_t n) {
  const auto* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = write(fd, p, n);
    if (w <= 0) return false;
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  return true;
}
bool read_all(int fd, void* data, std::size_t n) {
  auto* p = static_cast<char*>(data);
  while (n > 0) {
    const ssize_t r = read(fd, p, n);
    if (r <= 0) return false;
    p += r;
    n -= static_cast<std::size_t>(r);
  }
  return true;
}

// --- the subscriber process -----------------------------------------------------

class Subscriber {
 public:
  // libmosquitto's thread.
  void on_message(const mosquitto_message& msg) {
    const std::uint64_t now = realtime_ns();
    const std::string_view topic(msg.topic);
    const auto* data = static_cast<const std::uint8_t*>(msg.payload);
    const auto len = static_cast<std::size_t>(msg.payloadlen);
    const std::lock_guard lock(mu_);
    if (topic.find("/DBIRTH/") != std::string_view::npos) {
      ++tally_.births;
      return;
    }
    if (!live_ || topic.find("/DDATA/") == std::string_view::npos) {
      ++tally_.other;
      return;
    }
    tally_.ddata_bytes = len;
    const int found = for_each_position(data, len, [&](unsigned d, std::uint64_t k) { take(now, d, k); });
    if (found <= 0) ++tally_.other;
  }

  // One position: sample k of device d, arrived at `now`.
  void take(std::uint64_t now, unsigned d, std::uint64_t k) {
    if (k >= seen_.size() || d != k % kDevices) {
      ++tally_.other;
      return;
    }
    if (seen_[k] != 0) {
      ++tally_.duplicates;
      return;
    }
    seen_[k] = 1;
    ++tally_.received;
    const std::uint64_t rx = real0_ + k * 1000000000ull / rate_;  // the parent's schedule
    lat_.push_back(now > rx ? now - rx : 0);
    tally_.span_ns = now > real0_ ? now - real0_ : 0;
    if (last_[d] != kNone && k < last_[d]) ++tally_.out_of_order;
    else last_[d] = k;
  }

  // The child's main thread: one order, its answer written to `out`.
  bool handle(const Order& o, int out) {
    const std::lock_guard lock(mu_);
    if (o.kind == OrderKind::kArm) {
      live_ = false;
      tally_ = {};
    } else if (o.kind == OrderKind::kGo) {
      real0_ = o.real0_ns;
      rate_ = o.rate;
      seen_.assign(o.total, 0);
      lat_.clear();
      lat_.reserve(o.total);
      last_.fill(kNone);
      live_ = true;
    } else if (o.kind == OrderKind::kEnd) {
      live_ = false;
      return write_all(out, &tally_, sizeof tally_) && write_all(out, lat_.data(), lat_.size() * sizeof lat_[0]);
    }
    return write_all(out, &tally_, sizeof tally_);
  }

 private:
  static constexpr std::uint64_t kNone = ~0ull;
  std::mutex mu_;
  bool live_ = false;
  std::uint64_t real0_ = 0, rate_ = 1;
  std::vector<std::uint8_t> seen_;
  std::vector<std::uint64_t> lat_;
  std::array<std::uint64_t, kDevices> last_{};
  Tally tally_;
};

int subscriber_main(std::uint16_t port, int in, int out) {
  mosquitto_lib_init();
  Subscriber sub;
  static std::atomic<bool> subscribed{false};
  mosquitto* m = mosquitto_new("bench-subscriber", true, &sub);
  if (m == nullptr) return 1;
  mosquitto_message_callback_set(m, [](mosquitto*, void* self, const mosquitto_message* msg) {
    if (msg != nullptr && msg->topic != nullptr) static_cast<Subscriber*>(self)->on_message(*msg);
  });
  mosquitto_subscribe_callback_set(m, [](mosquitto*, void*, int, int, const int*) { subscribed = true; });
  if (mosquitto_connect(m, "127.0.0.1", port, 60) != MOSQ_ERR_SUCCESS ||
      mosquitto_subscribe(m, nullptr, "spBv1.0/bench/#", 0) != MOSQ_ERR_SUCCESS ||
      mosquitto_loop_start(m) != MOSQ_ERR_SUCCESS)
    return 1;
  for (int i = 0; i < 500 && !subscribed; ++i) usleep(10000);
  if (!subscribed) return 1;
  Order o;
  o.kind = OrderKind::kTally;
  bool ok = sub.handle(o, out);  // "ready"
  while (ok && read_all(in, &o, sizeof o) && o.kind != OrderKind::kQuit) ok = sub.handle(o, out);
  mosquitto_disconnect(m);
  mosquitto_loop_stop(m, false);
  mosquitto_destroy(m);
  mosquitto_lib_cleanup();
  return ok ? 0 : 1;
}

struct Child {
  pid_t pid = -1;
  int to = -1, from = -1;
  bool order(OrderKind kind, Tally& t, const Order& base = {}) {
    Order o = base;
    o.kind = kind;
    return write_all(to, &o, sizeof o) && read_all(from, &t, sizeof t);
  }
  // The run's tally; its latencies appended to `lat`.
  bool end(Tally& t, std::vector<std::uint64_t>& lat) {
    if (!order(OrderKind::kEnd, t)) return false;
    const std::size_t old = lat.size();
    lat.resize(old + t.received);
    return read_all(from, lat.data() + old, t.received * sizeof lat[0]);
  }
};

// Forks the subscriber before the parent has any thread; returns when it is
// subscribed.
bool start_child(std::uint16_t port, Child& c) {
  int down[2], up[2];
  if (pipe(down) != 0 || pipe(up) != 0) return false;
  c.pid = fork();
  if (c.pid == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    close(down[1]);
    close(up[0]);
    _exit(subscriber_main(port, down[0], up[1]));
  }
  close(down[0]);
  close(up[1]);
  c.to = down[1];
  c.from = up[0];
  Tally ready;
  return c.pid > 0 && read_all(c.from, &ready, sizeof ready);
}

// --- the gateway side -------------------------------------------------------------

// Sample k is due at mono0 + k / rate and was received at real0 + k / rate.
struct Schedule {
  std::uint64_t mono0 = 0, real0 = 0, rate = 1, total = 0;
  [[nodiscard]] std::uint64_t due(std::uint64_t k) const { return k * 1000000000ull / rate; }
  [[nodiscard]] std::uint64_t rx(std::uint64_t k) const { return real0 + due(k); }
};

// On each wake-up, take(first, n) gets the samples due by then (at most
// max_batch); then it sleeps until the next one is due.
template <typename Take>
void spread_feed(const Schedule& s, std::size_t max_batch, Take take) {
  sleep_until_mono(s.mono0);
  std::uint64_t k = 0;
  while (k < s.total) {
    const std::uint64_t elapsed = mono_ns() - s.mono0;
    std::size_t n = 0;
    while (k + n < s.total && n < max_batch && s.due(k + n) <= elapsed) ++n;
    if (n == 0) {
      sleep_until_mono(s.mono0 + s.due(k));
      continue;
    }
    take(k, n);
    k += n;
  }
}

// One publisher at one rate, summed over its slices.
struct RunResult {
  bool ok = true;
  unsigned slices = 0;
  std::uint64_t sent = 0;
  Tally tally;  // ddata_bytes: the last slice's
  std::vector<std::uint64_t> lat, cost;  // ns: receive stamp -> callback; the feeding thread's call per sample
  unsigned long long feed_allocs = 0, process_allocs = 0;
  std::vector<pipeline::OutputFigure> counters;  // the plugin's own, summed over the slices
  // From the first sample due until the subscriber has them all (or none
  // came for 1 s): wall time, and the CPU time of the broker, the subscriber
  // and this process (the publisher under test).
  double wall_s = 0, cpu_broker_s = 0, cpu_subscriber_s = 0, cpu_gateway_s = 0, cpu_feeding_s = 0;
  std::vector<std::pair<std::string, double>> cpu_threads;  // the other threads of this process, by name
  [[nodiscard]] std::uint64_t missing() const { return sent > tally.received ? sent - tally.received : 0; }
  [[nodiscard]] std::uint64_t counter(std::string_view name) const {
    for (const auto& f : counters)
      if (f.name == name) return f.value;
    return 0;
  }
  void add(const Tally& t) {
    tally.received += t.received;
    tally.duplicates += t.duplicates;
    tally.out_of_order += t.out_of_order;
    tally.births += t.births;
    tally.other += t.other;
    tally.ddata_bytes = t.ddata_bytes;
    tally.span_ns += t.span_ns;
  }
  // Samples/s the subscriber got while the stream ran: below the rate when
  // a backlog grew (the stream was not kept up).
  [[nodiscard]] double delivered_rate() const {
    return tally.span_ns != 0 ? static_cast<double>(tally.received) * 1e9 / static_cast<double>(tally.span_ns) : 0.0;
  }
};

// The plugin as the daemon runs it, the feeding thread in the dispatcher's place.
class PluginPublisher {
 public:
  explicit PluginPublisher(std::uint16_t port)
      : host_({std::filesystem::path(COBRIDGE_MQTT_PLUGIN_FILE).parent_path(), kEdge,
               [](pipeline::LogLevel, std::string_view, std::string_view m) {
                 std::fprintf(stderr, "  plugin: %.*s\n", static_cast<int>(m.size()), m.data());
               }}),
        port_(port),
        batch_(256) {}
  static constexpr const char* kLabel = "plugin";
  static constexpr const char* kCall = "on_samples per sample (feeding thread)";
  static std::uint64_t births() { return kDevices; }

  bool start() {
    // bdSeq in the temporary folder (its default is the daemon's /var/lib/cobridge).
    const std::string bdseq = (std::filesystem::temp_directory_path() / "cobridge-mqtt-bench.bdseq").string();
    const std::string config = "host = \"127.0.0.1\"\nport = " + std::to_string(port_) + "\ngroup_id = \"" +
                               kGroup + "\"\nedge_node_id = \"" + kEdge + "\"\nbdseq_file = \"" + bdseq + "\"\n";
    if (const Error err = host_.load({"mqtt", "mqtt", COBRIDGE_MQTT_PLUGIN_FILE, config})) {
      std::fprintf(stderr, "load failed: %s\n", err.message.c_str());
      return false;
    }
    if (!host_.start_all().empty()) return false;
    announce_devices(host_, kDevices, [](unsigned d) { return device_name(d); });
    return true;
  }
  void prepare(const Schedule& s) { cost_.reserve(s.total); }

  // Feeding thread: samples first .. first + n - 1 in one delivery.
  void take(const Schedule& s, std::uint64_t first, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) fill(batch_[i], s, first + i);
    const std::uint64_t t0 = mono_ns();
    host_.deliver(std::span<const pipeline::Sample>(batch_.data(), n));
    cost_.push_back((mono_ns() - t0) / n);
  }

  // Adds the plugin's counters to `sum`, then stops it.
  void stop(std::vector<pipeline::OutputFigure>& sum) {
    for (const pipeline::OutputStats& o : host_.stats()) {
      for (const pipeline::OutputFigure& f : o.figures) {
        if (!f.counter) continue;
        auto it = std::find_if(sum.begin(), sum.end(), [&](const auto& s) { return s.name == f.name; });
        if (it == sum.end()) {
          it = sum.insert(sum.end(), f);
          it->value = 0;
        }
        it->value += f.value;
      }
    }
    host_.stop_all();
  }
  std::vector<std::uint64_t>& cost() { return cost_; }

 private:
  static void fill(pipeline::Sample& p, const Schedule& s, std::uint64_t k) {
    p = pipeline::Sample{};
    const auto d = static_cast<unsigned>(k % kDevices);
    p.kind = COBRIDGE_SAMPLE_TPDO;
    p.device_index = static_cast<std::uint16_t>(d);
    p.bus_index = static_cast<std::uint8_t>(d / 8);
    p.node_id = static_cast<std::uint8_t>(1 + d % 8);
    p.sequence = static_cast<std::uint32_t>(k / kDevices + 1);
    p.rx_timestamp_ns = s.rx(k);
    p.publish_timestamp_ns = realtime_ns();
    p.position = static_cast<std::int64_t>(k);
    p.speed = static_cast<std::int32_t>(k & 0x7FFFFFFFu);
    p.valid = COBRIDGE_VALID_POSITION | COBRIDGE_VALID_SPEED;
  }

  pipeline::PluginHost host_;
  std::uint16_t port_;
  std::vector<pipeline::Sample> batch_;
  std::vector<std::uint64_t> cost_;
};

// The floor: one mosquitto_publish per sample of a payload encoded before the run.
class BarePublisher {
 public:
  explicit BarePublisher(std::uint16_t port) : port_(port) {}
  ~BarePublisher() {
    if (m_ == nullptr) return;
    mosquitto_disconnect(m_);
    mosquitto_loop_stop(m_, false);
    mosquitto_destroy(m_);
  }
  static constexpr const char* kLabel = "bare libmosquitto";
  static constexpr const char* kCall = "mosquitto_publish (feeding thread)";
  static std::uint64_t births() { return 0; }

  bool start() {
    mosquitto_lib_init();
    m_ = mosquitto_new("bench-bare", true, this);
    if (m_ == nullptr) return false;
    mosquitto_connect_callback_set(m_, [](mosquitto*, void* self, int rc) {
      if (rc == 0) static_cast<BarePublisher*>(self)->connected_ = true;
    });
    (void)mosquitto_int_option(m_, MOSQ_OPT_TCP_NODELAY, 1);  // as the plugin's client
    if (mosquitto_connect_async(m_, "127.0.0.1", port_, 60) != MOSQ_ERR_SUCCESS ||
        mosquitto_loop_start(m_) != MOSQ_ERR_SUCCESS)
      return false;
    for (int i = 0; i < 500 && !connected_; ++i) usleep(10000);
    return connected_;
  }

  // Every payload of the run, seq running 0..255 as the plugin's.
  void prepare(const Schedule& s) {
    for (unsigned d = 0; d < kDevices; ++d) topics_.push_back(ddata_topic(d));
    bytes_.reserve(s.total * 40);
    offsets_.reserve(s.total + 1);
    for (std::uint64_t k = 0; k < s.total; ++k) {
      offsets_.push_back(bytes_.size());
      // The plugin's seq: NBIRTH took 0, the 32 DBIRTHs 1..32.
      put_ddata(bytes_, k, s.rx(k) / 1000000u, static_cast<std::uint8_t>(k + 1 + kDevices));
    }
    offsets_.push_back(bytes_.size());
    cost_.reserve(s.total);
  }

  void take(const Schedule&, std::uint64_t first, std::size_t n) {
    for (std::uint64_t k = first; k < first + n; ++k) {
      const std::uint64_t t0 = mono_ns();
      (void)mosquitto_publish(m_, nullptr, topics_[k % kDevices].c_str(),
                              static_cast<int>(offsets_[k + 1] - offsets_[k]), bytes_.data() + offsets_[k], 0, false);
      cost_.push_back(mono_ns() - t0);
    }
  }
  void stop(std::vector<pipeline::OutputFigure>&) {}
  std::vector<std::uint64_t>& cost() { return cost_; }

 private:
  std::uint16_t port_;
  mosquitto* m_ = nullptr;
  std::atomic<bool> connected_{false};
  std::vector<std::string> topics_;
  std::vector<std::uint8_t> bytes_;
  std::vector<std::size_t> offsets_;
  std::vector<std::uint64_t> cost_;
};

// Polls the subscriber until `want` DBIRTHs arrived (5 s at most).
bool wait_births(Child& c, std::uint64_t want) {
  Tally t;
  for (int i = 0; i < 250; ++i) {
    if (!c.order(OrderKind::kTally, t)) return false;
    if (t.births >= want) return true;
    usleep(20000);
  }
  std::fprintf(stderr, "only %" PRIu64 " of %" PRIu64 " DBIRTHs arrived\n", t.births, want);
  return false;
}

// Until every sample arrived or none for 1 s (30 s at most): a backlog in
// the plugin or the broker is waited for, not counted as lost.
void wait_drained(Child& c, std::uint64_t sent) {
  Tally t;
  std::uint64_t last = 0;
  for (int i = 0, quiet = 0; i < 600 && quiet < 20; ++i) {
    usleep(50000);
    if (!c.order(OrderKind::kTally, t)) return;
    if (t.received >= sent) return;
    quiet = t.received == last ? quiet + 1 : 0;
    last = t.received;
  }
}

// Feeds the schedule through `pub` on this (the feeding) thread, counting
// its allocations and the whole process's.
template <typename Publisher>
void feed(Publisher& pub, const Schedule& s, RunResult& r) {
  prctl(PR_SET_TIMERSLACK, 1000UL, 0, 0, 0);
  bench::start_counting_allocations();
  bench::start_counting_this_thread();
  spread_feed(s, 256, [&](std::uint64_t first, std::size_t n) { pub.take(s, first, n); });
  r.feed_allocs += bench::stop_counting_this_thread();
  r.process_allocs += bench::stop_counting_allocations();
  prctl(PR_SET_TIMERSLACK, 0UL, 0, 0, 0);  // back to the default for threads created later
  r.sent += s.total;
}

// Who the runs talk to: the broker (its port, its pid) and the subscriber.
struct Bed {
  std::uint16_t port = 0;
  pid_t broker = -1;
  Child child;
};

// The CPU figures of a run, as differences of the figures taken at its start.
struct CpuMark {
  double wall, broker, subscriber, gateway, feeding;
  explicit CpuMark(const Bed& bed)
      : wall(static_cast<double>(mono_ns()) / 1e9),
        broker(cpu_seconds(bed.broker)),
        subscriber(cpu_seconds(bed.child.pid)),
        gateway(cpu_seconds(getpid())),
        feeding(cpu_seconds("/proc/self/task/" + std::to_string(getpid()) + "/stat")) {}
  void since(const CpuMark& start, RunResult& r) const {
    r.wall_s += wall - start.wall;
    r.cpu_broker_s += broker - start.broker;
    r.cpu_subscriber_s += subscriber - start.subscriber;
    r.cpu_gateway_s += gateway - start.gateway;
    r.cpu_feeding_s += feeding - start.feeding;
    add_thread_cpu(r.cpu_threads);
  }
};

// One slice: `seconds` of the stream at `rate` through a new publisher
// (the plugin loaded and started again), added to `r`.
template <typename Publisher>
bool run_slice(Bed& bed, unsigned rate, double seconds, RunResult& r) {
  r.ok = false;
  Child& child = bed.child;
  Publisher pub(bed.port);
  Tally t;
  if (!child.order(OrderKind::kArm, t) || !pub.start() || !wait_births(child, Publisher::births())) return false;
  Schedule s;
  s.rate = rate;
  s.total = static_cast<std::uint64_t>(seconds * rate);
  s.mono0 = mono_ns() + 500000000ull;  // room for prepare()
  s.real0 = realtime_ns() + 500000000ull;
  pub.prepare(s);
  Order go;
  go.real0_ns = s.real0;
  go.rate = s.rate;
  go.total = s.total;
  if (!child.order(OrderKind::kGo, t, go)) return false;
  sleep_until_mono(s.mono0);
  const CpuMark start(bed);
  feed(pub, s, r);
  wait_drained(child, s.total);
  CpuMark(bed).since(start, r);
  pub.stop(r.counters);
  if (!child.end(t, r.lat)) return false;
  r.add(t);
  r.cost.insert(r.cost.end(), pub.cost().begin(), pub.cost().end());
  ++r.slices;
  r.ok = true;
  return true;
}

template <typename Publisher>
void print_run(unsigned rate, RunResult& r) {
  const char* label = Publisher::kLabel;
  std::printf("%s, %u samples/s, %u slices: %" PRIu64 " sent, %" PRIu64 " received, %" PRIu64 " missing, %" PRIu64
              " duplicated, %" PRIu64 " out of order; DDATA %" PRIu64 " bytes; %" PRIu64 " other messages\n",
              label, rate, r.slices, r.sent, r.tally.received, r.missing(), r.tally.duplicates,
              r.tally.out_of_order, r.tally.ddata_bytes, r.tally.other);
  print("rx_timestamp -> subscriber callback", figures(r.lat));
  print(Publisher::kCall, figures(r.cost));
  const double n = r.sent != 0 ? static_cast<double>(r.sent) : 1.0;
  std::printf("  heap allocations: feeding thread %llu (%.4f per sample), whole process %llu (%.2f per sample)\n",
              r.feed_allocs, static_cast<double>(r.feed_allocs) / n, r.process_allocs,
              static_cast<double>(r.process_allocs) / n);
  std::printf("  delivered %.0f samples/s (first receive stamp to last arrival); CPU in %.1f s: broker %.2f s, "
              "subscriber %.2f s, gateway side %.2f s (feeding thread %.2f s",
              r.delivered_rate(), r.wall_s, r.cpu_broker_s, r.cpu_subscriber_s, r.cpu_gateway_s, r.cpu_feeding_s);
  for (const auto& [name, cpu] : r.cpu_threads) std::printf(", '%s' %.2f s", name.c_str(), cpu);
  std::printf(")\n");
  if (r.counters.empty()) return;
  std::printf("  plugin counters, all slices:");
  for (const pipeline::OutputFigure& f : r.counters) std::printf(" %s=%" PRIu64, f.name.c_str(), f.value);
  std::printf("\n");
}

// The lines scripts/bench reads.
void print_figures(unsigned rate, RunResult& plugin, RunResult& bare) {
  const Figures p = figures(plugin.lat);
  const Figures b = figures(bare.lat);
  std::printf("FIGURE mqtt rate=%u plugin p50=%.1f p99=%.1f p99.9=%.1f us | bare p50=%.1f p99=%.1f p99.9=%.1f us"
              " | p99 ratio %.2f\n",
              rate, us(p.p50), us(p.p99), us(p.p999), us(b.p50), us(b.p99), us(b.p999),
              b.p99 != 0 ? static_cast<double>(p.p99) / static_cast<double>(b.p99) : 0.0);
  std::printf("FIGURE mqtt rate=%u loss plugin missing=%" PRIu64 " out_of_order=%" PRIu64 " of %" PRIu64
              " (plugin's drops %" PRIu64 ") | bare missing=%" PRIu64 " out_of_order=%" PRIu64 " of %" PRIu64 "\n",
              rate, plugin.missing(), plugin.tally.out_of_order, plugin.sent, plugin.counter("mqtt_drops"),
              bare.missing(), bare.tally.out_of_order, bare.sent);
  std::printf("FIGURE mqtt rate=%u delivered plugin=%.0f bare=%.0f samples/s\n", rate, plugin.delivered_rate(),
              bare.delivered_rate());
  const auto cores = [](const RunResult& r, double cpu_s) { return r.wall_s > 0 ? cpu_s / r.wall_s : 0.0; };
  std::printf("FIGURE mqtt rate=%u cpu cores plugin broker=%.2f subscriber=%.2f gateway=%.2f | bare broker=%.2f "
              "subscriber=%.2f gateway=%.2f\n",
              rate, cores(plugin, plugin.cpu_broker_s), cores(plugin, plugin.cpu_subscriber_s),
              cores(plugin, plugin.cpu_gateway_s), cores(bare, bare.cpu_broker_s), cores(bare, bare.cpu_subscriber_s),
              cores(bare, bare.cpu_gateway_s));
  const Figures call = figures(plugin.cost);
  std::printf("FIGURE mqtt rate=%u allocations feeding thread=%llu whole process=%llu in %" PRIu64
              " samples | bare feeding thread=%llu | on_samples per sample p50=%.2f p99=%.2f us\n",
              rate, plugin.feed_allocs, plugin.process_allocs, plugin.sent, bare.feed_allocs, us(call.p50),
              us(call.p99));
}

std::vector<unsigned> parse_rates(const char* text) {
  std::vector<unsigned> rates;
  for (const char* p = text; *p != '\0';) {
    char* end = nullptr;
    const unsigned long v = std::strtoul(p, &end, 10);
    if (end == p || v == 0 || v > 1000000) return {};
    rates.push_back(static_cast<unsigned>(v));
    p = *end == ',' ? end + 1 : end;
    if (*end != ',' && *end != '\0') return {};
  }
  return rates;
}


// Each rate: bare and plugin in alternating slices, so that a change in the
// rest of the host's load (a build beside the bench) hits both alike.
bool run_rate(Bed& bed, unsigned rate, double seconds, unsigned slices) {
  RunResult bare, plugin;
  const double slice = seconds / slices;
  for (unsigned i = 0; i < slices; ++i) {
    if (!run_slice<BarePublisher>(bed, rate, slice, bare) || !run_slice<PluginPublisher>(bed, rate, slice, plugin)) {
      std::fprintf(stderr, "slice %u at %u samples/s did not complete\n", i + 1, rate);
      return false;
    }
  }
  print_run<BarePublisher>(rate, bare);
  print_run<PluginPublisher>(rate, plugin);
  print_figures(rate, plugin, bare);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 10.0;
  const std::vector<unsigned> rates = parse_rates(argc > 2 ? argv[2] : "32000,1000");
  const int slices = argc > 3 ? std::atoi(argv[3]) : 5;
  if (seconds <= 0 || rates.empty() || slices < 1) {
    std::fprintf(stderr, "usage: %s [seconds per publisher and rate > 0] [rate,rate,...] [slices >= 1]\n", argv[0]);
    return 2;
  }
  setvbuf(stdout, nullptr, _IOLBF, 0);  // lines stay whole next to the plugin's log on stderr
  Broker broker;
  if (!broker.start()) {
    std::fprintf(stderr, "cannot start %s on a loopback port\n", COBRIDGE_MOSQUITTO_BROKER);
    return 1;
  }
  Bed bed;
  bed.port = broker.port;
  bed.broker = broker.pid;
  if (!start_child(broker.port, bed.child)) {
    std::fprintf(stderr, "the subscriber did not start\n");
    return 1;
  }
  int major = 0, minor = 0, rev = 0;
  mosquitto_lib_version(&major, &minor, &rev);
  std::printf("MQTT bench: %s on 127.0.0.1:%u, libmosquitto %d.%d.%d, subscriber in a separate process, "
              "%u devices, host: %ld CPUs\n",
              COBRIDGE_MOSQUITTO_BROKER, broker.port, major, minor, rev, kDevices, sysconf(_SC_NPROCESSORS_ONLN));
  int status = 0;
  for (const unsigned rate : rates) {
    if (!run_rate(bed, rate, seconds, static_cast<unsigned>(slices))) {
      status = 1;
      break;
    }
  }
  Order quit;
  quit.kind = OrderKind::kQuit;  // not answered: the child disconnects and exits
  (void)write_all(bed.child.to, &quit, sizeof quit);
  waitpid(bed.child.pid, nullptr, 0);
  return status;
}
