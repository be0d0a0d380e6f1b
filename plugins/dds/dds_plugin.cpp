// Cyclone DDS output plugin (libcobridge_dds.so): the C entry point and ops
// table of cobridge/plugin.h around DdsPublisher.
//
// Configuration (TOML keys of the instance's table, see docs/dds.md):
//   domain             = 0              DDS domain id
//   sample_reliability = "best-effort"  or "reliable" (EncoderSample only)
//   sample_depth       = 1              EncoderSample keep-last depth
//   topic_prefix       = ""             prepended to the topic names
//   partition          = ""             DDS partition of every writer
//   write_batch        = true           one RTPS message per drained batch
//   liveliness_lease_ms = 500           writers' liveliness lease
//   sample_path        = "auto"         who writes EncoderSample (auto, dispatcher, writer-thread)
//   [security]                          DDS Security: six files, all or none (dds_security.hpp)
//
// Threads: create/start/stop/destroy on the daemon's control thread;
// on_samples/on_device on the dispatcher thread, which the plugin never
// blocks: samples are copied into the plugin's own SPSC ring (a full ring
// drops and counts, never waits) and device announcements into a small
// locked queue; the plugin's writer thread does every dds_write, taking
// whatever is queued at once (with write_batch: one RTPS message per take).
// So a slow or reliable DDS subscriber cannot delay the other outputs
// (Modbus, tap), which share the dispatcher. The hop costs a wake-up
// (docs/performance.md, "DDS latency"). Except for EncoderSample (sample_path
// "auto", the default, and "dispatcher"): on_samples writes those itself,
// never waiting (DispatcherSamples: max_blocking_time 0; with "auto" what
// finds a reliable history full is spilled to the writer thread, which
// waits for room), and queues only what the writer thread needs, waking it
// only then. A third, slow thread (presence)
// keeps the gateway's GatewayStatus current every kPresenceTick and reports
// a duplicate gateway id in the domain (gateway_presence.hpp); the writer
// thread wakes it at once when the device counts change, and it writes
// GatewayStatus again every kPresenceRefresh (alive again after a lease
// lost to starvation).
//
// Status lane: heartbeat, NMT and STATUS samples are queued twice,
// in the sample ring (their order among the TPDOs: the stale re-publication)
// and in a small status ring that the writer thread serves first and again
// every kLaneCheck samples of a batch. A reliable subscriber that lags, or a
// loaded host, can leave seconds of EncoderSamples in the sample ring; a
// device going offline must not wait behind them (measured: 2.5-3.3 s
// behind, 4.2-4.8 s in earlier runs; target 1 s). Cost: one more ring push
// per status sample (rare) and one empty-ring check per kLaneCheck samples.
#include "dds/dds_config.hpp"
#include "dds/dds_publisher.hpp"
#include "dds/dds_security.hpp"
#include "dds/dispatcher_samples.hpp"
#include "dds/bus_health_table.hpp"
#include "dds/gateway_presence.hpp"
#include "dds/topics.hpp"

#include <cobridge/plugin.h>
#include <cobridge/spsc_ring.hpp>

#include "host_log.hpp"


#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace cobridge::dds {
namespace {

// A device announcement with its own copies of the strings (the host's
// pointers are valid only during on_device).
struct OwnedDevice {
  cobridge_device_info info{};
  std::string name, bus_name, model, family, position_unit;
  const cobridge_device_info& fixed() {
    info.name = name.c_str();
    info.bus_name = bus_name.c_str();
    info.model = model.c_str();
    info.family = family.c_str();
    info.position_unit = position_unit.c_str();
    return info;
  }
};

struct Instance {
  static constexpr std::size_t kRing = 1u << 16;  // ~16 s of four saturated buses' worth of bursts
  static constexpr std::size_t kBatch = 256;
  static constexpr std::chrono::milliseconds kStopDrain{300};
  static constexpr std::chrono::milliseconds kPresenceTick{100};
  // GatewayStatus is written again this often even without a change: a
  // gateway starved past its liveliness lease (a loaded host) turns not
  // alive at the subscribers, and only a new sample makes it alive again.
  static constexpr std::chrono::milliseconds kPresenceRefresh{1000};
  static constexpr std::size_t kLane = 1024;     // status samples: 10/s per device heartbeats and changes
  static constexpr std::size_t kLaneCheck = 8;   // samples written between looks at the lane

  const cobridge_host_api* host = nullptr;
  std::unique_ptr<DdsPublisher> publisher;
  std::unique_ptr<DispatcherSamples> direct;  // set when samples are written on the dispatcher
  std::unique_ptr<GatewayPresence> presence;
  std::unique_ptr<PairRole> pair;  // hot standby only (host->redundancy_node)
  BusHealthTable bus_health;       // ABI 5 on_bus, for GatewayStatus.bus_health
  std::thread presence_thread;
  std::mutex presence_mutex;
  std::condition_variable presence_cv;
  bool presence_stop = false;  // under presence_mutex
  bool presence_kick = false;  // under presence_mutex: the counts changed
  GatewayCounts kicked{};      // writer thread: the counts the presence thread was last woken for
  SpscRing<cobridge_sample> ring{kRing};
  SpscRing<cobridge_sample> lane{kLane};  // status samples, also in `ring` (see the top)
  std::array<cobridge_sample, kLane> lane_batch{};
  std::mutex device_mutex;
  std::deque<OwnedDevice> devices;          // pending announcements
  std::atomic<bool> devices_pending{false}; // set with devices non-empty
  std::atomic<std::uint32_t> wakeups{0};    // bumped by producers; the writer waits on it
  std::atomic<bool> running{false};
  std::atomic<std::uint64_t> ring_drops{0};
  std::uint64_t stop_drops = 0;         // left in the queue when the stop's drain time ran out
  std::chrono::milliseconds stop_drain{};  // how long the final drain took
  std::thread writer;
  std::array<cobridge_sample, kBatch> batch{};
  std::array<SpilledSample, kBatch> spilled{};

  // Samples lost because the writer thread fell behind: its queue's and the
  // spill ring's.
  [[nodiscard]] std::uint64_t dropped() const noexcept {
    return ring_drops.load(std::memory_order_relaxed) + (direct ? direct->spill_drops() : 0);
  }

  void log(int level, const std::string& msg) const noexcept {
    plugin::host_log(host, level, msg);
  }

  // Dispatcher thread: into the sample ring, and a status sample into the
  // lane too. Only what the ring took goes to the lane; a full lane only
  // means the ring's copy is applied, later (DeviceSlots, by sequence).
  bool queue(const cobridge_sample& s) noexcept {
    if (!ring.try_push(s)) return false;
    if (is_status_kind(s)) (void)lane.try_push(s);
    return true;
  }

  void wake() noexcept {
    wakeups.fetch_add(1, std::memory_order_release);
    wakeups.notify_one();
  }

  // Applies pending announcements, then writes queued samples; returns
  // whether anything was done.
  bool drain() {
    bool any = drain_devices();
    if (drain_lane()) any = true;
    if (drain_spilled()) any = true;
    // A few batches per turn, so that a stop is seen between them even with
    // a long backlog behind a slow reliable subscriber.
    for (int i = 0; i < 4 && drain_batch(); ++i) any = true;
    kick_presence();
    return any;
  }

  // Status samples ahead of the sample ring (DdsPublisher::publish_status).
  bool drain_lane() {
    const std::size_t n = lane.pop_batch(std::span<cobridge_sample>(lane_batch.data(), lane_batch.size()));
    if (n == 0) return false;
    (void)drain_devices();  // after the pop: see drain_batch
    publisher->publish_status({lane_batch.data(), n});
    kick_presence();
    return true;
  }

  // EncoderSamples the dispatcher could not write, in order; each waits up to
  // kMaxBlocking for room in the reliable history. Flushed before the
  // dispatcher is told, so its next direct write goes out after them.
  bool drain_spilled() {
    if (!direct) return false;
    const std::size_t n = direct->take_spilled(std::span<SpilledSample>(spilled.data(), spilled.size()));
    if (n == 0) return false;
    (void)drain_devices();  // after the pop: see drain_batch
    for (std::size_t i = 0; i < n; ++i) {
      publisher->write_spilled(spilled[i].sample, spilled[i].stale, kMaxBlocking);
      if ((i + 1) % kLaneCheck == 0) (void)drain_lane();
    }
    publisher->flush();
    direct->spilled_done(n);
    return true;
  }

  // GatewayStatus follows a role change now (dispatcher thread).
  void wake_presence() {
    {
      std::lock_guard lock(presence_mutex);
      presence_kick = true;
    }
    presence_cv.notify_one();
  }

  // GatewayStatus follows a change of the counts now, not at the next tick.
  void kick_presence() {
    const GatewayCounts c = publisher->counts();
    if (c == kicked) return;
    kicked = c;
    {
      std::lock_guard lock(presence_mutex);
      presence_kick = true;
    }
    presence_cv.notify_one();
  }

  bool drain_devices() {
    bool any = false;
    // Checked first: an empty std::deque allocates, and drain runs on every
    // wake-up while announcements are rare.
    if (devices_pending.exchange(false, std::memory_order_acquire)) {
      std::deque<OwnedDevice> todo;
      {
        std::lock_guard lock(device_mutex);
        todo.swap(devices);
      }
      for (auto& d : todo) {
        publisher->device(d.fixed());
        any = true;
      }
    }
    return any;
  }

  bool drain_batch() {
    const std::size_t n = ring.pop_batch(std::span<cobridge_sample>(batch.data(), batch.size()));
    if (n == 0) return false;
    // After the pop, not only before it: a device announced and then given
    // samples between drain()'s first look and this pop must be known before
    // they are written, or they go out without its name. The pop's acquire
    // makes the announcement queued before them visible here.
    (void)drain_devices();
    for (std::size_t at = 0; at < n; at += kLaneCheck) {
      publisher->write_samples({batch.data() + at, std::min(kLaneCheck, n - at)});
      (void)drain_lane();  // flushes what was written before it, when it has anything
    }
    publisher->flush();
    return true;
  }

  // What was queued before the stop still goes out, for at most kStopDrain:
  // a reliable subscriber that lags must not hold up the daemon's shutdown
  // (SIGTERM is done in 1 s); what is left is counted in the stop report.
  void final_drain() {
    const auto t0 = std::chrono::steady_clock::now();
    (void)drain_devices();
    while (std::chrono::steady_clock::now() - t0 < kStopDrain && (drain_spilled() || drain_batch())) {
    }
    for (std::size_t n; (n = ring.pop_batch(std::span<cobridge_sample>(batch.data(), batch.size()))) != 0;)
      stop_drops += n;
    if (direct) {
      for (std::size_t n; (n = direct->take_spilled(std::span<SpilledSample>(spilled.data(), spilled.size()))) != 0;)
        stop_drops += n;
    }
    stop_drain = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - t0);
  }

  void run() {
    while (running.load(std::memory_order_acquire)) {
      const std::uint32_t seen = wakeups.load(std::memory_order_acquire);
      if (drain()) continue;
      wakeups.wait(seen, std::memory_order_acquire);  // until a producer bumps it
    }
    final_drain();
  }

  // Presence thread: GatewayStatus when the counts change, duplicate ids.
  void run_presence() {
    std::unique_lock lock(presence_mutex);
    auto refresh_at = std::chrono::steady_clock::now() + kPresenceRefresh;
    while (!presence_stop) {
      lock.unlock();
      const DuplicateChange d = presence->poll();
      const auto now = std::chrono::steady_clock::now();
      const bool refresh = now >= refresh_at;
      // Forced when the other one disposed our key (kGone), and every kPresenceRefresh.
      const std::uint64_t writes = presence->writes();
      presence->publish(publisher->counts(), pair ? pair->snapshot() : PairStatus{}, bus_health.snapshot(),
                        d == DuplicateChange::kGone || refresh);
      if (refresh || presence->writes() != writes) refresh_at = now + kPresenceRefresh;
      try {
        report(d);
      } catch (...) {
        // Logging is best effort.
      }
      lock.lock();
      presence_cv.wait_for(lock, kPresenceTick, [this] { return presence_stop || presence_kick; });
      presence_kick = false;
    }
  }
  void report(DuplicateChange d) const {
    if (d == DuplicateChange::kDetected) {
      log(COBRIDGE_LOG_ERROR, "duplicate gateway.id '" + std::string(publisher->gateway().id) + "' in DDS domain " +
                                  std::to_string(publisher->config().domain) + ": " + presence->duplicate_of() +
                                  " publishes under the same id, so the devices of both collide; give each gateway "
                                  "its own [gateway] id");
    } else if (d == DuplicateChange::kGone) {
      log(COBRIDGE_LOG_INFO, "the other gateway with this gateway.id has left the DDS domain");
    }
  }
  void start_presence() {
    presence_stop = false;
    presence_thread = std::thread([this] { run_presence(); });
  }
  void stop_presence() {
    {
      std::lock_guard lock(presence_mutex);
      presence_stop = true;
    }
    presence_cv.notify_all();
    if (presence_thread.joinable()) presence_thread.join();
    if (presence) presence->stop();
  }

  void start_writer() {
    running.store(true, std::memory_order_release);
    writer = std::thread([this] { run(); });
  }
  void stop_writer() {
    if (!running.exchange(false)) return;
    wake();
    if (writer.joinable()) writer.join();
  }
};

using plugin::copy_error;

int dds_start(void* self) {
  auto* inst = static_cast<Instance*>(self);
  try {
    std::string note;
    if (const plugin::Error e = inst->publisher->start(note)) {
      inst->log(COBRIDGE_LOG_ERROR, e.to_string());
      return -1;
    }
    if (!note.empty()) inst->log(COBRIDGE_LOG_WARN, note);
    const DdsConfig& cfg = inst->publisher->config();
    inst->presence = std::make_unique<GatewayPresence>(inst->publisher->gateway(), cfg.topic_prefix, cfg.partition,
                                                       DDS_MSECS(cfg.liveliness_lease_ms));
    if (inst->pair) inst->presence->set_pair_node(inst->pair->node());
    if (plugin::Error e = inst->presence->start(inst->publisher->participant())) {
      if (cfg.security && e.code.category() == dds_category())
        e.message += security_failure_hint(-e.code.value(), *cfg.security);
      inst->log(COBRIDGE_LOG_ERROR, e.to_string());
      inst->presence.reset();
      inst->publisher->stop();
      return -1;
    }
    if (inst->direct) inst->direct->attach(inst->publisher->sample_writer());
    inst->start_writer();
    inst->start_presence();
    const DdsConfig& c = inst->publisher->config();
    inst->log(COBRIDGE_LOG_INFO, "publishing on domain " + std::to_string(c.domain) + ", samples " +
                                     std::string(to_string(c.sample_reliability)) + " keep-last " +
                                     std::to_string(c.sample_depth) +
                                     (c.write_batch ? ", write batching" : "") + ", liveliness lease " +
                                     std::to_string(c.liveliness_lease_ms) + " ms, samples written by the " +
                                     (!inst->direct                                  ? "writer thread"
                                      : c.spill_to_writer_thread() ? "dispatcher (spilling to the writer thread)"
                                                                   : "dispatcher") +
                                     (c.topic_prefix.empty() ? std::string() : ", topic prefix '" + c.topic_prefix + "'") +
                                     (c.partition.empty() ? std::string() : ", partition '" + c.partition + "'"));
    inst->log(COBRIDGE_LOG_INFO, security_log_line(c.security ? &*c.security : nullptr));
    return 0;
  } catch (const std::exception& e) {
    inst->log(COBRIDGE_LOG_ERROR, std::string("start: ") + e.what());
  } catch (...) {
    inst->log(COBRIDGE_LOG_ERROR, "start: unknown exception");
  }
  inst->publisher->stop();
  return -1;
}

void dds_stop(void* self) {
  auto* inst = static_cast<Instance*>(self);
  if (inst->direct) inst->direct->detach();  // the dispatcher no longer calls in
  inst->stop_writer();
  inst->stop_presence();  // disposes GatewayStatus: subscribers see the gateway leave at once
  const auto t0 = std::chrono::steady_clock::now();
  inst->publisher->stop();
  const auto deleted = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - t0);
  const PublisherStats s = inst->publisher->stats();
  try {
    const std::uint64_t samples = s.samples + (inst->direct ? inst->direct->written() : 0);
    std::string msg = "stopped: " + std::to_string(samples) + " samples, " + std::to_string(s.events) +
                      " events, " + std::to_string(s.statuses) + " status updates written (final drain " +
                      std::to_string(inst->stop_drain.count()) + " ms, DDS entities deleted in " +
                      std::to_string(deleted.count()) + " ms)";
    if (inst->direct && inst->direct->spilled() != 0)
      msg += "; " + std::to_string(inst->direct->spilled()) +
             " samples handed to the writer thread (reliable history full, or the dispatcher behind)";
    if (const auto drops = inst->dropped(); drops != 0)
      msg += "; " + std::to_string(drops) + " samples dropped because the DDS writer fell behind";
    if (inst->stop_drops != 0)
      msg += "; " + std::to_string(inst->stop_drops) + " queued samples not written at stop (drain limit " +
             std::to_string(Instance::kStopDrain.count()) + " ms)";
    const std::uint64_t failures = s.write_failures + (inst->direct ? inst->direct->failures() : 0);
    const std::int32_t last = inst->direct && inst->direct->failures() != 0 ? inst->direct->last_failure()
                                                                             : s.last_failure;
    if (failures != 0) {
      msg += "; " + std::to_string(failures) + " writes failed (last: " + dds_strretcode(last) + ")";
    }
    inst->log(failures != 0 ? COBRIDGE_LOG_WARN : COBRIDGE_LOG_INFO, msg);
  } catch (...) {
    // Logging is best effort; stop itself has succeeded.
  }
}

void dds_destroy(void* self) {
  auto* inst = static_cast<Instance*>(self);
  inst->stop_writer();
  inst->stop_presence();
  delete inst;
}

void dds_on_samples(void* self, const cobridge_sample* samples, std::size_t count) {
  if (samples == nullptr || count == 0) return;
  auto* inst = static_cast<Instance*>(self);
  std::uint64_t dropped = 0;
  if (inst->direct && inst->direct->attached()) {
    std::size_t queued = 0;
    for (std::size_t i = 0; i < count; ++i) {
      if (!inst->direct->write(samples[i])) continue;
      if (inst->queue(samples[i])) {
        ++queued;
      } else {
        ++dropped;
      }
    }
    inst->direct->flush();
    if (dropped != 0) inst->ring_drops.fetch_add(dropped, std::memory_order_relaxed);
    if (queued != 0 || inst->direct->spilling()) inst->wake();
    return;
  }
  for (std::size_t i = 0; i < count; ++i)
    if (!inst->queue(samples[i])) ++dropped;
  if (dropped != 0) inst->ring_drops.fetch_add(dropped, std::memory_order_relaxed);
  inst->wake();
}

void dds_on_device(void* self, const cobridge_device_info* info) {
  // Every field used exists since ABI 1; the size check keeps a shorter
  // layout from an unexpected host from being read past its end.
  if (info == nullptr ||
      info->struct_size < offsetof(cobridge_device_info, position_unit) + sizeof(const char*)) {
    return;
  }
  auto* inst = static_cast<Instance*>(self);
  if (inst->direct) inst->direct->device(*info);
  try {
    OwnedDevice d;
    d.info = *info;
    d.name = info->name ? info->name : "";
    d.bus_name = info->bus_name ? info->bus_name : "";
    d.model = info->model ? info->model : "";
    d.family = info->family ? info->family : "";
    d.position_unit = info->position_unit ? info->position_unit : "";
    std::lock_guard lock(inst->device_mutex);
    inst->devices.push_back(std::move(d));
    inst->devices_pending.store(true, std::memory_order_release);
  } catch (...) {
    return;  // out of memory: the announcement is lost, samples still flow
  }
  inst->wake();
}

// ABI 4: the gateway's role on a bus changed (hot standby). Dispatcher
// thread, between two batches: the writers' strength changes before the
// next sample is written.
void dds_on_role(void* self, const cobridge_role_info* info) {
  if (info == nullptr || info->struct_size < offsetof(cobridge_role_info, cause) + sizeof(const char*)) return;
  auto* inst = static_cast<Instance*>(self);
  if (!inst->pair || !inst->publisher || !inst->publisher->started()) return;
  try {
    if (inst->pair->update(*info)) {
      const std::int32_t strength = inst->pair->strength();
      if (const plugin::Error e = inst->publisher->set_ownership_strength(strength)) {
        inst->log(COBRIDGE_LOG_ERROR, "cannot set the writers' ownership strength to " + std::to_string(strength) +
                                          ": " + e.to_string() + "; subscribers may keep the other gateway's stream");
      } else {
        inst->log(COBRIDGE_LOG_INFO, std::string("hot standby: writing at ownership strength ") +
                                         std::to_string(strength) +
                                         (strength >= kMasterStrength ? " (master)" : " (standby)"));
      }
    }
    inst->wake_presence();
  } catch (...) {
    // Out of memory: the role shows at the next change.
  }
}

// ABI 5: a bus's health (CAN controller); GatewayStatus says it. Dispatcher
// thread: a copy under a mutex and a wake-up; the presence thread writes.
void dds_on_bus(void* self, const cobridge_bus_info* info) {
  if (info == nullptr) return;
  auto* inst = static_cast<Instance*>(self);
  try {
    if (inst->bus_health.update(*info) && inst->presence) inst->wake_presence();
  } catch (...) {
    // Out of memory: the health shows at the next change.
  }
}

// ABI 3: what the status page and /metrics show of this output. Control-plane
// thread, between start and stop: atomics and one Cyclone status query per writer.
std::size_t dds_stats(void* self, cobridge_stat* out, std::size_t max) {
  const auto* inst = static_cast<const Instance*>(self);
  if (!inst->publisher || !inst->publisher->started()) return 0;
  const PublisherStats s = inst->publisher->stats();
  const DdsPublisher::WriterCounts w = inst->publisher->writer_counts();
  const std::uint64_t samples = s.samples + (inst->direct ? inst->direct->written() : 0);
  const std::uint64_t failures = s.write_failures + (inst->direct ? inst->direct->failures() : 0);
  const cobridge_stat figures[] = {
      {"dds_writers", "DDS data writers (EncoderSample, EncoderEvent, DeviceStatus).", COBRIDGE_STAT_GAUGE, 0, w.writers},
      {"dds_matched_readers", "DDS readers matched to those writers now.", COBRIDGE_STAT_GAUGE, 0, w.matched_readers},
      {"dds_samples_written", "EncoderSample writes.", COBRIDGE_STAT_COUNTER, 0, samples},
      {"dds_events_written", "EncoderEvent writes.", COBRIDGE_STAT_COUNTER, 0, s.events},
      {"dds_write_failures", "DDS writes that failed (a full reliable history included).", COBRIDGE_STAT_COUNTER, 0,
       failures},
      {"dds_samples_dropped", "Samples dropped because the DDS writer thread fell behind.", COBRIDGE_STAT_COUNTER, 0,
       inst->dropped()},
      {"dds_samples_spilled",
       "EncoderSamples the dispatcher handed to the writer thread (reliable history full, or dispatcher behind).",
       COBRIDGE_STAT_COUNTER, 0, inst->direct ? inst->direct->spilled() : 0},
  };
  return plugin::copy_stats(figures, out, max);
}

// ABI 4: a gateway of a hot-standby pair writes with EXCLUSIVE ownership.
void join_pair(Instance& inst, const cobridge_host_api& host, DdsConfig& config) {
  if (host.struct_size < offsetof(cobridge_host_api, redundancy_node) + sizeof(host.redundancy_node)) return;
  if (host.redundancy_node == 0 || host.redundancy_node >= 128) return;
  config.redundancy_node = static_cast<std::uint8_t>(host.redundancy_node);
  inst.pair = std::make_unique<PairRole>(config.redundancy_node);
}

constexpr cobridge_plugin_ops kOps = {
    COBRIDGE_PLUGIN_ABI_VERSION,
    sizeof(cobridge_plugin_ops),
    "dds",
    &dds_start,
    &dds_stop,
    &dds_destroy,
    &dds_on_samples,
    &dds_on_device,
    &dds_stats,
    &dds_on_role,
    &dds_on_bus,
};

}  // namespace
}  // namespace cobridge::dds

extern "C" COBRIDGE_PLUGIN_EXPORT int cobridge_plugin_create(const cobridge_host_api* host, const char* config_toml,
                                                             size_t config_len, const cobridge_plugin_ops** ops_out,
                                                             void** self_out, char* err, size_t err_len) {
  using namespace cobridge::dds;
  return cobridge::plugin::create_plugin(
      "dds", &kOps, host, config_toml, config_len, ops_out, self_out, err, err_len,
      [host](std::string_view config, cobridge::plugin::Error& error) -> void* {
        DdsConfigResult parsed = parse_dds_config(config);
        if (!parsed.ok()) {
          error = std::move(parsed.error);
          return nullptr;
        }
        const char* gateway_id = host->gateway_id != nullptr ? host->gateway_id : "";
        auto inst = std::make_unique<Instance>();
        inst->host = host;
        const bool direct = parsed.config.samples_on_dispatcher();
        const bool spill = parsed.config.spill_to_writer_thread();
        const bool batch = parsed.config.write_batch;
        join_pair(*inst, *host, parsed.config);
        inst->publisher = std::make_unique<DdsPublisher>(std::move(parsed.config), gateway_id);
        if (direct) inst->direct = std::make_unique<DispatcherSamples>(inst->publisher->gateway(), batch, spill);
        if (*gateway_id == '\0') {
          inst->log(COBRIDGE_LOG_WARN, "the gateway id is empty: keys of several gateways in one domain will collide");
        }
        return inst.release();
      });
}
