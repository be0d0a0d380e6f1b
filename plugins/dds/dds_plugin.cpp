// Cyclone DDS output plugin (libcobridge_dds.so): the C entry point and ops
// table of cobridge/plugin.h around DdsPublisher.
//
// Configuration (TOML keys of the instance's table, see docs/dds.md):
//   domain             = 0              DDS domain id
//   sample_reliability = "best-effort"  or "reliable" (EncoderSample only)
//   sample_depth       = 1              EncoderSample keep-last depth
//   topic_prefix       = ""             prepended to the topic names
//   write_batch        = true           one RTPS message per drained batch
//
// Threads: create/start/stop/destroy on the daemon's control thread;
// on_samples/on_device on the dispatcher thread, which the plugin never
// blocks: samples are copied into the plugin's own SPSC ring (a full ring
// drops and counts, never waits) and device announcements into a small
// locked queue; the plugin's writer thread does every dds_write, taking
// whatever is queued at once (with write_batch: one RTPS message per take).
// So a slow or reliable DDS subscriber cannot delay the other outputs
// (Modbus, tap), which share the dispatcher. The hop costs a wake-up
// (docs/performance.md, "DDS latency").
#include "dds/dds_config.hpp"
#include "dds/dds_publisher.hpp"

#include <cobridge/plugin.h>

#include "host_log.hpp"

#include "pipeline/spsc_ring.hpp"

#include <array>
#include <atomic>
#include <chrono>
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

  const cobridge_host_api* host = nullptr;
  std::unique_ptr<DdsPublisher> publisher;
  pipeline::SpscRing<cobridge_sample> ring{kRing};
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

  void log(int level, const std::string& msg) const noexcept {
    plugin::host_log(host, level, msg);
  }

  void wake() noexcept {
    wakeups.fetch_add(1, std::memory_order_release);
    wakeups.notify_one();
  }

  // Applies pending announcements, then writes queued samples; returns
  // whether anything was done.
  bool drain() {
    bool any = drain_devices();
    // A few batches per turn, so that a stop is seen between them even with
    // a long backlog behind a slow reliable subscriber.
    for (int i = 0; i < 4 && drain_batch(); ++i) any = true;
    return any;
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
    publisher->publish({batch.data(), n});
    return true;
  }

  // What was queued before the stop still goes out, for at most kStopDrain:
  // a reliable subscriber that lags must not hold up the daemon's shutdown
  // (SIGTERM is done in 1 s); what is left is counted in the stop report.
  void final_drain() {
    const auto t0 = std::chrono::steady_clock::now();
    (void)drain_devices();
    while (std::chrono::steady_clock::now() - t0 < kStopDrain && drain_batch()) {
    }
    for (std::size_t n; (n = ring.pop_batch(std::span<cobridge_sample>(batch.data(), batch.size()))) != 0;)
      stop_drops += n;
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
    std::string message, note;
    if (const std::error_code ec = inst->publisher->start(message, note)) {
      inst->log(COBRIDGE_LOG_ERROR, message);
      return -1;
    }
    if (!note.empty()) inst->log(COBRIDGE_LOG_WARN, note);
    inst->start_writer();
    const DdsConfig& c = inst->publisher->config();
    inst->log(COBRIDGE_LOG_INFO, "publishing on domain " + std::to_string(c.domain) + ", samples " +
                                     std::string(to_string(c.sample_reliability)) + " keep-last " +
                                     std::to_string(c.sample_depth) +
                                     (c.write_batch ? ", write batching" : "") +
                                     (c.topic_prefix.empty() ? std::string() : ", topic prefix '" + c.topic_prefix + "'"));
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
  inst->stop_writer();
  const auto t0 = std::chrono::steady_clock::now();
  inst->publisher->stop();
  const auto deleted = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - t0);
  const PublisherStats s = inst->publisher->stats();
  try {
    std::string msg = "stopped: " + std::to_string(s.samples) + " samples, " + std::to_string(s.events) +
                      " events, " + std::to_string(s.statuses) + " status updates written (final drain " +
                      std::to_string(inst->stop_drain.count()) + " ms, DDS entities deleted in " +
                      std::to_string(deleted.count()) + " ms)";
    if (const auto drops = inst->ring_drops.load(); drops != 0)
      msg += "; " + std::to_string(drops) + " samples dropped because the DDS writer fell behind";
    if (inst->stop_drops != 0)
      msg += "; " + std::to_string(inst->stop_drops) + " queued samples not written at stop (drain limit " +
             std::to_string(Instance::kStopDrain.count()) + " ms)";
    if (s.write_failures != 0) {
      msg += "; " + std::to_string(s.write_failures) + " writes failed (last: " + dds_strretcode(s.last_failure) + ")";
    }
    inst->log(s.write_failures != 0 ? COBRIDGE_LOG_WARN : COBRIDGE_LOG_INFO, msg);
  } catch (...) {
    // Logging is best effort; stop itself has succeeded.
  }
}

void dds_destroy(void* self) {
  auto* inst = static_cast<Instance*>(self);
  inst->stop_writer();
  delete inst;
}

void dds_on_samples(void* self, const cobridge_sample* samples, std::size_t count) {
  if (samples == nullptr || count == 0) return;
  auto* inst = static_cast<Instance*>(self);
  std::uint64_t dropped = 0;
  for (std::size_t i = 0; i < count; ++i)
    if (!inst->ring.try_push(samples[i])) ++dropped;
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

constexpr cobridge_plugin_ops kOps = {
    COBRIDGE_PLUGIN_ABI_VERSION,
    sizeof(cobridge_plugin_ops),
    "dds",
    &dds_start,
    &dds_stop,
    &dds_destroy,
    &dds_on_samples,
    &dds_on_device,
    nullptr,  // stats (ABI 3)
};

}  // namespace
}  // namespace cobridge::dds

extern "C" COBRIDGE_PLUGIN_EXPORT int cobridge_plugin_create(const cobridge_host_api* host, const char* config_toml,
                                                             size_t config_len, const cobridge_plugin_ops** ops_out,
                                                             void** self_out, char* err, size_t err_len) {
  using namespace cobridge::dds;
  if (host == nullptr || ops_out == nullptr || self_out == nullptr) {
    copy_error(err, err_len, "dds: null argument");
    return -1;
  }
  try {
    DdsConfigResult parsed =
        parse_dds_config(std::string_view(config_toml != nullptr ? config_toml : "", config_toml ? config_len : 0));
    if (!parsed.ok()) {
      copy_error(err, err_len, parsed.message);
      return -1;
    }
    const char* gateway_id = host->gateway_id != nullptr ? host->gateway_id : "";
    auto inst = std::make_unique<Instance>();
    inst->host = host;
    inst->publisher = std::make_unique<DdsPublisher>(std::move(parsed.config), gateway_id);
    if (*gateway_id == '\0') {
      inst->log(COBRIDGE_LOG_WARN, "the gateway id is empty: keys of several gateways in one domain will collide");
    }
    *ops_out = &kOps;
    *self_out = inst.release();
    return 0;
  } catch (const std::exception& e) {
    copy_error(err, err_len, std::string("dds: ") + e.what());
  } catch (...) {
    copy_error(err, err_len, "dds: unknown exception");
  }
  return -1;
}
