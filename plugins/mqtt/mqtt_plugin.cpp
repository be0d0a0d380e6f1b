// The Sparkplug B over MQTT output plugin (libcobridge_mqtt.so): entry point,
// ops table and the publisher thread. See docs/mqtt.md.
//
// Threads:
//   - dispatcher (on_samples, on_device): copies each sample / device record
//     into a bounded SpscRing, rings the Doorbell once per call and
//     returns; a full ring counts a drop. No allocation, lock or log there;
//     a system call (one futex wake) only when the publisher sleeps, so at
//     most one per call and none while the stream keeps it busy (the same
//     hop as the DDS plugin's writer thread; bench: mqtt, on_samples time).
//   - publisher (ours): drains the rings, runs the EdgeSession (births,
//     DDATA, DDEATH) and hands messages to libmosquitto; polls the link's
//     flags (session gained/lost, rebirth, primary host); takes DCMDs to the
//     CommandDesk and publishes their results. Idle, it waits on a Doorbell
//     the dispatcher rings (at most 1 ms: the link's flags are polled).
//   - libmosquitto's client thread (MosquittoLink): socket, keepalive, reconnects
//     (a first CONNECT that failed at once: retried by the publisher thread).
//
// A hot-standby pair is one edge node (ABI 4 on_role): only the gateway that
// is master of a bus holds the Sparkplug session. on_role sets the wanted
// role; the publisher thread follows it: becoming master, it ends its
// observing connection and connects as the edge node (bdSeq following the
// one it heard, births at once); losing the role while it runs, it publishes
// NDEATH itself, disconnects (no will then) and observes again.
//   - control thread: create/start/stop/destroy; control plane: stats.
#include "bdseq_file.hpp"
#include "command_desk.hpp"
#include "device_record.hpp"
#include "doorbell.hpp"
#include "edge_session.hpp"
#include "mosquitto_link.hpp"
#include "mqtt_config.hpp"

#include <cobridge/plugin.h>
#include <cobridge/spsc_ring.hpp>

#include "host_log.hpp"

#include <array>
#include <atomic>
#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <thread>

namespace cobridge::mqtt {
namespace {

class LinkPublisher final : public Publisher {
 public:
  explicit LinkPublisher(MosquittoLink& link) : link_(link) {}
  bool publish(const std::string& topic, std::span<const std::uint8_t> payload) override {
    return link_.publish(topic, payload);
  }

 private:
  MosquittoLink& link_;
};

struct Plugin {
  const cobridge_host_api* host = nullptr;
  MqttConfig config;
  std::unique_ptr<SpscRing<cobridge_sample>> samples;
  std::unique_ptr<SpscRing<DeviceRecord>> devices;
  std::unique_ptr<BdSeqFile> bd_seq;
  std::unique_ptr<MosquittoLink> link;
  std::unique_ptr<LinkPublisher> publisher;
  std::unique_ptr<EdgeSession> session;
  std::unique_ptr<CommandDesk> desk;
  std::thread worker;
  std::atomic<bool> running{false};
  std::atomic<std::uint64_t> ring_drops{0};  // dispatcher side
  Doorbell bell;  // the dispatcher rings it after queueing; the publisher waits on it
  // Hot standby: 0 = alone (always the edge node); else per bus roles
  // (dispatcher thread only) and whether this gateway is master of one.
  std::uint32_t pair_node = 0;
  std::array<std::uint8_t, 256> roles{};
  std::atomic<bool> want_master{false};
  bool publishing = false;  // publisher thread: the link is the edge node's session
  std::uint64_t takeover_deadline_ms = 0;  // publisher thread: waiting for the old master's NDEATH
  // Publisher thread: when the session ended for the primary host connects
  // again (0: no such reconnect pending). See restart_for_primary().
  std::uint64_t reconnect_at_ms = 0;
  std::atomic<bool> active{false};  // for stats

  void log(int level, const std::string& msg) const noexcept { plugin::host_log(host, level, msg); }

  // host->submit_command exists from ABI 2 on.
  [[nodiscard]] bool host_takes_commands() const noexcept {
    return host->struct_size >= offsetof(cobridge_host_api, submit_command) + sizeof(host->submit_command) &&
           host->submit_command != nullptr;
  }

  void make_desk() {
    CommandDesk::Submit submit;
    if (host_takes_commands()) submit = [h = host](const cobridge_command& c) { return h->submit_command(h->host, &c); };
    desk = std::make_unique<CommandDesk>(config.writes, std::move(submit),
                                         [this](int level, const std::string& m) { log(level, m); });
  }

  // DCMDs the link decoded: to the desk; a refusal is published at once.
  bool take_commands() {
    bool busy = false;
    DcmdRequest r;
    while (link->take_dcmd(r)) {
      busy = true;
      const int index = session->device_index_of(r.device_id);
      const char* name = index >= 0 ? session->device_name(static_cast<std::uint16_t>(index)) : "";
      if (auto result = desk->on_dcmd(r, index, name)) session->publish_result(*result, wall_ms());
    }
    return busy;
  }

  void poll_link(std::uint64_t& generation, int& primary) {
    link->service(std::chrono::steady_clock::now());
    const MosquittoLink::State st = link->state();
    const std::uint64_t now = wall_ms();
    if (st.generation != generation) {
      generation = st.generation;
      session->set_link(st.connected && !st.observing, st.bd_seq, now);
    }
    const int p = link->primary_state();
    if (p != primary) {
      const bool went_offline = primary == 1 && p == 0;
      primary = p;
      if (went_offline && publishing) return restart_for_primary(generation, primary);
      session->set_primary_online(p == 1, now);
    }
    if (link->take_rebirth()) session->rebirth(now);
  }

  // The primary host went offline (its STATE, newer than the last): the edge
  // node ends its session (NDEATH published, disconnect) and connects again
  // with the next bdSeq, then waits for STATE online before its births
  // (Sparkplug 3.0, 5: tck-id-operational-behavior-primary-application-state-
  // with-multiple-servers-walk; with one server configured the next server
  // is the same). Data meanwhile goes to the store-and-forward buffers.
  // The new CONNECT waits kReconnectAfterMs: with the same client id, one
  // that reached the broker before the old connection's DISCONNECT would
  // take that session over, and the broker would publish its will, a
  // second NDEATH (seen in 2 of 6 runs of vcan_outputs_mqtt_session
  // without the wait). Births wait for the host anyway.
  static constexpr std::uint64_t kReconnectAfterMs = 500;
  void restart_for_primary(std::uint64_t& generation, int& primary) {
    link->stop();
    session->set_primary_online(false, wall_ms());  // births wait for its next online
    session->set_link(false, 0, wall_ms());
    generation = link->state().generation;
    primary = -1;
    reconnect_at_ms = wall_ms() + kReconnectAfterMs;
    log(COBRIDGE_LOG_WARN, "primary host " + config.primary_host_id +
                               " offline (STATE): NDEATH published and the session ended; reconnecting to wait for it");
  }

  // Publisher thread, each pass: the reconnect restart_for_primary() scheduled.
  void reconnect_when_due() {
    if (reconnect_at_ms == 0 || wall_ms() < reconnect_at_ms) return;
    reconnect_at_ms = 0;
    if (const plugin::Error e = link->start(std::nullopt, MosquittoLink::Mode::kPublish))
      log(COBRIDGE_LOG_ERROR, "cannot start the MQTT client again: " + e.to_string());
  }

  // One pass: returns whether anything was done (else the thread naps).
  bool drain() {
    bool busy = false;
    DeviceRecord rec;
    while (devices->try_pop(rec)) {
      session->on_device(rec, wall_ms());
      busy = true;
    }
    std::array<cobridge_sample, 256> batch;
    const std::size_t n = samples->pop_batch(batch);
    const std::uint64_t now = wall_ms();
    for (std::size_t i = 0; i < n; ++i) {
      session->on_sample(batch[i], now);
      if (batch[i].kind == COBRIDGE_SAMPLE_COMMAND)
        if (auto result = desk->on_sample(batch[i])) session->publish_result(*result, now);
    }
    session->flush();  // the pass's DDATA, one message per device
    return take_commands() || busy || n != 0;
  }

  // A new master connects once the old master's NDEATH is heard (its will,
  // or its own on losing the role), so that a host never sees two sessions
  // alive; at most this long, for an old master cut off from the broker too.
  static constexpr std::uint64_t kTakeoverWaitMs = 700;

  // Whether a takeover must still wait for the old session's NDEATH.
  bool await_old_death() {
    if (!link->connected() || link->seen_dead()) {
      takeover_deadline_ms = 0;
      return false;
    }
    const std::uint64_t now = wall_ms();
    if (takeover_deadline_ms == 0) takeover_deadline_ms = now + kTakeoverWaitMs;
    if (now < takeover_deadline_ms) return true;
    takeover_deadline_ms = 0;
    log(COBRIDGE_LOG_WARN, "hot standby: no NDEATH of the previous master heard within " +
                               std::to_string(kTakeoverWaitMs) + " ms; connecting as the edge node anyway");
    return false;
  }

  // Publisher thread: the pair's role into the link's mode (see the file comment).
  void follow_role() {
    const bool want = want_master.load(std::memory_order_acquire);
    if (pair_node == 0 || want == publishing) {
      takeover_deadline_ms = 0;
      return;
    }
    if (want && await_old_death()) return;
    const std::optional<std::uint8_t> heard = link->seen_bd_seq();
    reconnect_at_ms = 0;  // the role's start below replaces a pending reconnect
    link->stop();  // as the edge node: publishes NDEATH first (spec 5, intentional disconnect)
    session->set_link(false, 0, wall_ms());
    session->set_active(want);
    publishing = want;
    active.store(want, std::memory_order_release);
    const plugin::Error e = want ? link->start(heard, MosquittoLink::Mode::kPublish)
                                 : link->start(std::nullopt, MosquittoLink::Mode::kObserve);
    log(e ? COBRIDGE_LOG_ERROR : COBRIDGE_LOG_INFO,
        want ? "hot standby: master now, connecting as edge node " + config.edge_node_id +
                   (heard ? " after the bdSeq " + std::to_string(*heard) + " it heard" : std::string())
             : "hot standby: not master any more: NDEATH published, observing as the standby" +
                   (e ? ": " + e.to_string() : std::string()));
  }

  void run() {
    std::uint64_t generation = 0;
    int primary = -1;
    while (running.load(std::memory_order_acquire)) {
      // The rings first: a pass woken by the doorbell publishes before it
      // spends system calls on the client's socket and flags.
      const bool busy = drain();
      follow_role();
      reconnect_when_due();
      poll_link(generation, primary);
      if (!busy && !link->wants_write())
        bell.wait(std::chrono::milliseconds(1),
                  [this] { return samples->size_approx() != 0 || devices->size_approx() != 0; });
    }
  }
};

int mqtt_start(void* self) {
  auto* p = static_cast<Plugin*>(self);
  try {
    const auto log = [p](int level, const std::string& m) { p->log(level, m); };
    p->bd_seq = std::make_unique<BdSeqFile>(p->config.bdseq_file, log);
    p->bd_seq->load();
    p->link = std::make_unique<MosquittoLink>(p->config, *p->bd_seq, log);
    p->publisher = std::make_unique<LinkPublisher>(*p->link);
    EdgeSession::Ids ids{p->config.group_id, p->config.edge_node_id, !p->config.primary_host_id.empty(),
                         std::size_t{p->config.store_seconds} * p->config.store_rate,
                         std::uint64_t{p->config.store_seconds} * 1000u, p->config.batch_samples,
                         p->config.metrics};
    p->session = std::make_unique<EdgeSession>(ids, p->config.deadband, *p->publisher);
    p->make_desk();
    if (p->config.writes.enabled && !p->host_takes_commands())
      p->log(COBRIDGE_LOG_WARN, "writes_enabled = true, but this daemon (plugin ABI " +
                                    std::to_string(p->host->abi_version) + ") takes no commands: DCMDs are refused");
    // A pair member starts as an observer and becomes the edge node when master.
    p->publishing = p->pair_node == 0;
    p->active.store(p->publishing, std::memory_order_release);
    p->session->set_active(p->publishing);
    if (const plugin::Error e = p->link->start(std::nullopt, p->publishing ? MosquittoLink::Mode::kPublish
                                                                             : MosquittoLink::Mode::kObserve)) {
      p->log(COBRIDGE_LOG_ERROR, "cannot start the MQTT client: " + e.to_string());
      p->link.reset();
      return -1;
    }
    p->running.store(true, std::memory_order_release);
    p->worker = std::thread([p] { p->run(); });
    p->log(COBRIDGE_LOG_INFO, "Sparkplug B edge node " + p->config.group_id + "/" + p->config.edge_node_id +
                                  " publishing to " + p->config.host + ":" + std::to_string(p->config.port) +
                                  (p->config.tls() ? " (TLS)" : "") +
                                  (p->config.primary_host_id.empty() ? ""
                                                                     : ", waiting for primary host " +
                                                                           p->config.primary_host_id));
    return 0;
  } catch (const std::exception& e) {
    p->log(COBRIDGE_LOG_ERROR, std::string("cannot start: ") + e.what());
  }
  p->link.reset();
  return -1;
}

void mqtt_stop(void* self) {
  auto* p = static_cast<Plugin*>(self);
  p->running.store(false, std::memory_order_release);
  if (p->worker.joinable()) p->worker.join();
  if (p->link) p->link->stop();
  p->link.reset();
}

void mqtt_destroy(void* self) {
  auto* p = static_cast<Plugin*>(self);
  mqtt_stop(p);
  delete p;
}

void mqtt_on_samples(void* self, const cobridge_sample* samples, std::size_t count) {
  auto* p = static_cast<Plugin*>(self);
  for (std::size_t i = 0; i < count; ++i)
    if (!p->samples->try_push(samples[i])) p->ring_drops.fetch_add(1, std::memory_order_relaxed);
  if (count != 0) p->bell.ring();
}

void mqtt_on_device(void* self, const cobridge_device_info* info) {
  auto* p = static_cast<Plugin*>(self);
  if (info == nullptr || info->struct_size < offsetof(cobridge_device_info, serial) + sizeof(info->serial)) return;
  if (!p->devices->try_push(from_info(*info))) p->ring_drops.fetch_add(1, std::memory_order_relaxed);
  p->bell.ring();
}

// ABI 4: a bus's role changed (hot standby). Dispatcher thread: records
// it and sets a flag the publisher thread follows.
void mqtt_on_role(void* self, const cobridge_role_info* info) {
  auto* p = static_cast<Plugin*>(self);
  if (info == nullptr || info->struct_size < offsetof(cobridge_role_info, role) + sizeof(info->role)) return;
  p->roles[info->bus_index] = info->role;
  bool master = false;
  for (const std::uint8_t r : p->roles) master = master || r == COBRIDGE_ROLE_MASTER;
  p->want_master.store(master, std::memory_order_release);
}

// ABI 3: control-plane thread; loads atomics only.
std::size_t mqtt_stats(void* self, cobridge_stat* out, std::size_t max) {
  const auto* p = static_cast<const Plugin*>(self);
  if (!p->session || !p->link) return 0;
  const SessionCounters& c = p->session->counters();
  const auto load = [](const std::atomic<std::uint64_t>& a) { return a.load(std::memory_order_relaxed); };
  const cobridge_stat figures[] = {
      {"mqtt_connected", "1 while the MQTT connection to the broker is up.", COBRIDGE_STAT_GAUGE, 0,
       p->link->connected() ? 1u : 0u},
      {"mqtt_edge_node", "1 while this gateway is the Sparkplug edge node (0: the standby of a pair).",
       COBRIDGE_STAT_GAUGE, 0, p->active.load(std::memory_order_acquire) ? 1u : 0u},
      {"mqtt_births", "Sparkplug NBIRTH and DBIRTH messages published.", COBRIDGE_STAT_COUNTER, 0, load(c.births)},
      {"mqtt_deaths", "Sparkplug DDEATH messages published.", COBRIDGE_STAT_COUNTER, 0, load(c.deaths)},
      {"mqtt_messages", "Sparkplug messages handed to the MQTT client.", COBRIDGE_STAT_COUNTER, 0, load(c.messages)},
      {"mqtt_bytes", "Payload bytes of those messages.", COBRIDGE_STAT_COUNTER, 0, load(c.bytes)},
      {"mqtt_drops", "Messages not sent (broker away without a store, client refused) and samples lost to a full queue.",
       COBRIDGE_STAT_COUNTER, 0, load(c.drops) + p->ring_drops.load(std::memory_order_relaxed)},
      {"mqtt_stored", "DDATA entries stored while the broker was away (store and forward).", COBRIDGE_STAT_COUNTER,
       0, load(c.stored)},
      {"mqtt_store_drops", "Stored entries dropped, oldest first (store full or older than store_seconds).",
       COBRIDGE_STAT_COUNTER, 0, load(c.store_drops)},
      {"mqtt_replayed", "Stored entries sent as historical DDATA after the births.", COBRIDGE_STAT_COUNTER, 0,
       load(c.replayed)},
  };
  return plugin::copy_stats(figures, out, max);
}

constexpr cobridge_plugin_ops kOps = {
    COBRIDGE_PLUGIN_ABI_VERSION,
    sizeof(cobridge_plugin_ops),
    "mqtt",
    &mqtt_start,
    &mqtt_stop,
    &mqtt_destroy,
    &mqtt_on_samples,
    &mqtt_on_device,
    &mqtt_stats,
    &mqtt_on_role,
    nullptr,  // on_bus: bus health is not published as Sparkplug metrics yet
};

}  // namespace
}  // namespace cobridge::mqtt

extern "C" COBRIDGE_PLUGIN_EXPORT int cobridge_plugin_create(const cobridge_host_api* host, const char* config_toml,
                                                             size_t config_len, const cobridge_plugin_ops** ops_out,
                                                             void** self_out, char* err, size_t err_len) {
  using namespace cobridge::mqtt;
  return cobridge::plugin::create_plugin(
      "mqtt", &kOps, host, config_toml, config_len, ops_out, self_out, err, err_len,
      [host](std::string_view config, cobridge::plugin::Error& error) -> void* {
        auto p = std::make_unique<Plugin>();
        p->host = host;
        error = parse_config(config, host->gateway_id != nullptr ? host->gateway_id : "", p->config);
        if (error) return nullptr;
        // A warning, not a refusal (a broker on a private segment may be
        // plaintext by choice); logged at load, so --check-config shows it.
        if (const std::string w = plaintext_warning(p->config); !w.empty()) p->log(COBRIDGE_LOG_WARN, w);
        if (host->abi_version >= 4 && host->struct_size >= offsetof(cobridge_host_api, redundancy_node) +
                                                              sizeof(host->redundancy_node))
          p->pair_node = host->redundancy_node;
        // Two gateways of a pair on one broker need two client ids (the
        // broker would otherwise drop one for the other, MQTT 3.1.1 3.1.4).
        if (p->pair_node != 0 && p->config.client_id == "cobridge-" + p->config.edge_node_id)
          p->config.client_id += "-" + std::to_string(p->pair_node);
        p->samples = std::make_unique<cobridge::SpscRing<cobridge_sample>>(p->config.queue_depth);
        p->devices = std::make_unique<cobridge::SpscRing<DeviceRecord>>(256);
        return p.release();
      });
}
