// MosquittoLink: the plugin's MQTT client on libmosquitto, run on the
// plugin's publisher thread (libmosquitto's loop, not its thread). Why: a
// threaded client never writes in mosquitto_publish (it queues the packet and
// wakes its own thread), so every sample crossed two threads, dispatcher to
// publisher to libmosquitto's, and each wake-up a loaded 2-CPU host delays
// showed at p99 (docs/performance.md, mqtt). Here mosquitto_publish writes
// the socket at once, and service() runs the loop once per pass without
// waiting: reads (NCMD, DCMD, STATE), keepalive, writes the socket refused
// before, and the reconnects. It owns what the MQTT session must carry for
// Sparkplug:
//   - the will: NDEATH with the current bdSeq, QoS 1, not retained
//     (spec 5: tck-id-topics-ndeath-will-message-*), set before every CONNECT;
//   - bdSeq: the next of BdSeqFile (persisted) for each new CONNECT, the
//     first one and every one after a lost session, so the NBIRTH that
//     follows names the will that the broker holds;
//   - reconnects with exponential backoff (1 s doubling to 30 s); a first
//     CONNECT that fails at once (broker not up yet, name not resolvable
//     yet: a plant's boot order) is retried by retry_connect(), because
//     libmosquitto's thread waits for a first connect for ever and never
//     retries it (found when the package test's broker started late);
//   - NCMD (Node Control/Rebirth) and the primary host's STATE, subscribed
//     at each connect and turned into flags the publisher thread polls;
//   - DCMD of every device (spBv1.0/<group>/DCMD/<edge>/+), decoded here and
//     queued for the publisher thread (a full queue drops the DCMD, logged);
//   - an observing mode for the standby of a hot-standby pair: connected
//     with no will, publishing nothing, subscribed to the edge node's own
//     NBIRTH and NDEATH only, to learn the bdSeq the master's session uses
//     (so that a takeover's NBIRTH continues from it, spec 6.4.x bdSeq);
//   - a bound on what waits in libmosquitto's own queue (it has none for
//     QoS 0): a broker or network slower than the encoders makes publish()
//     refuse, counted as a drop, instead of growing the daemon's memory.
//
// Thread contract: one thread at a time: start/stop on the daemon's control
// thread before the publisher thread runs and after it is joined, and on the
// publisher thread while it runs; publish(), service() and the take/poll
// functions on the publisher thread. The callbacks run inside service()
// (and stop()), so on that thread too. state(), connected() and the
// counters are atomics: the control plane reads them for stats.
#pragma once

#include "bdseq_file.hpp"
#include "dcmd_request.hpp"
#include "mqtt_config.hpp"
#include "sparkplug_payload.hpp"

#include <cobridge/plugin_error.hpp>
#include <cobridge/spsc_ring.hpp>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <span>
#include <string>

struct mosquitto;
struct mosquitto_message;

namespace cobridge::mqtt {

class MosquittoLink {
 public:
  using LogFn = std::function<void(int level, const std::string& msg)>;

  // What the publisher thread reads: a generation that changes with every
  // session gained or lost, whether the session is up, and its bdSeq.
  struct State {
    std::uint64_t generation = 0;
    bool connected = false;
    bool observing = false;  // connected as a standby's observer: no Sparkplug session
    std::uint8_t bd_seq = 0;
  };

  enum class Mode : std::uint8_t {
    kPublish,  // the edge node's session: the NDEATH will, births, data
    kObserve,  // a standby: no will, no messages, the edge node's bdSeq heard
  };

  MosquittoLink(const MqttConfig& config, BdSeqFile& bd_seq, LogFn log);
  ~MosquittoLink();
  MosquittoLink(const MosquittoLink&) = delete;
  MosquittoLink& operator=(const MosquittoLink&) = delete;

  // Creates the client, sets credentials, TLS and the will, starts the
  // connect (asynchronously: a broker that is away is retried, not fatal).
  // `after`: a bdSeq the pair's other gateway used last (the first CONNECT's follows it).
  [[nodiscard]] plugin::Error start(std::optional<std::uint8_t> after = std::nullopt, Mode mode = Mode::kPublish);
  // Publishes NDEATH itself (an intentional disconnect, spec 5:
  // tck-id-operational-behavior-edge-node-intentional-disconnect-ndeath),
  // disconnects (the DISCONNECT written, up to 0.5 s) and frees the client.
  void stop();

  // Publisher thread, each pass: with no socket open (a CONNECT that
  // failed at once, a session lost), connects again when due (1 s, doubling
  // to 30 s); else runs libmosquitto's loop once without waiting: at once
  // while packets wait for the socket or the CONNACK is awaited, else at
  // most every kLoopPeriod. Each run is a few system calls (select, clock,
  // read), and the publisher passes up to 1000 times a second even idle:
  // run each time, they slowed the whole UML guest of the MQTT end-to-end
  // test (its DDATA 0.4-1 s late in 2 of 5 runs, none before).
  void service(std::chrono::steady_clock::time_point now);
  static constexpr std::chrono::milliseconds kLoopPeriod{10};
  // Whether no socket is open and a CONNECT waits for service() (tests).
  [[nodiscard]] bool awaiting_connect() const noexcept { return mosq_ != nullptr && !socket_open_; }
  // Whether packets wait for the socket to take them (the publisher does
  // not nap then: service() writes them).
  [[nodiscard]] bool wants_write() const noexcept;

  // Messages handed to libmosquitto and not yet written to the socket, at most.
  static constexpr std::uint64_t kMaxQueued = 4096;

  // QoS 0, not retained, written to the socket at once when it takes it.
  // False when not connected, kMaxQueued are waiting, or the client refused it.
  [[nodiscard]] bool publish(const std::string& topic, std::span<const std::uint8_t> payload);

  [[nodiscard]] State state() const noexcept;
  // True once per NCMD Node Control/Rebirth = true received.
  [[nodiscard]] bool take_rebirth() noexcept { return rebirth_.exchange(false, std::memory_order_acq_rel); }
  // The primary host's last STATE: -1 none heard, 0 offline, 1 online.
  [[nodiscard]] int primary_state() const noexcept { return primary_.load(std::memory_order_acquire); }
  [[nodiscard]] bool connected() const noexcept { return connected_.load(std::memory_order_acquire); }
  // The bdSeq last seen in the edge node's NBIRTH or NDEATH while observing.
  [[nodiscard]] std::optional<std::uint8_t> seen_bd_seq() const noexcept {
    const int v = seen_bd_seq_.load(std::memory_order_acquire);
    return v < 0 ? std::nullopt : std::optional<std::uint8_t>(static_cast<std::uint8_t>(v));
  }
  // Whether the last of them was an NDEATH (no session of the edge node alive).
  [[nodiscard]] bool seen_dead() const noexcept { return seen_dead_.load(std::memory_order_acquire); }
  [[nodiscard]] Mode mode() const noexcept { return mode_; }
  // The next DCMD received, decoded (publisher thread).
  [[nodiscard]] bool take_dcmd(DcmdRequest& out) noexcept { return dcmds_.try_pop(out); }

 private:
  static void on_connect(struct mosquitto* m, void* self, int rc);
  static void on_disconnect(struct mosquitto* m, void* self, int rc);
  static void on_message(struct mosquitto* m, void* self, const struct mosquitto_message* msg);
  static void on_publish(struct mosquitto* m, void* self, int mid);
  static void on_log(struct mosquitto* m, void* self, int level, const char* text);

  void set_will();
  void handle_ncmd(const void* payload, int len);
  void handle_state(std::string_view text);
  void handle_dcmd(std::string_view topic, const void* payload, int len);
  void subscribe_all(struct mosquitto* m);
  [[nodiscard]] plugin::Error configure_client();
  [[nodiscard]] int connect(std::chrono::steady_clock::time_point now);
  void connect_later(std::chrono::steady_clock::time_point now);
  void flush(std::chrono::milliseconds limit);

  const MqttConfig& config_;
  BdSeqFile& bd_file_;
  LogFn log_;
  struct mosquitto* mosq_ = nullptr;
  bool socket_open_ = false;  // a CONNECT started and its socket not closed since
  // The next CONNECT when no socket is open, and the delay after it.
  std::chrono::steady_clock::time_point retry_at_{};
  std::chrono::steady_clock::time_point next_loop_{};  // service(): the next loop when nothing presses
  std::chrono::seconds retry_delay_{1};
  std::string ndeath_topic_;
  std::string ncmd_topic_;
  std::string state_topic_;
  std::string dcmd_prefix_;  // "spBv1.0/<group>/DCMD/<edge>/"
  std::string nbirth_topic_;
  Mode mode_ = Mode::kPublish;  // set by start()
  std::atomic<int> seen_bd_seq_{-1};
  std::atomic<bool> seen_dead_{false};
  SpscRing<DcmdRequest> dcmds_{64};  // on_message -> take_dcmd: a bound on what waits
  PayloadBuilder will_builder_;
  std::atomic<std::uint64_t> generation_{0};
  std::atomic<bool> connected_{false};
  std::atomic<std::uint8_t> bd_seq_{0};
  std::atomic<bool> rebirth_{false};
  std::atomic<int> primary_{-1};
  std::int64_t state_stamp_ = -1;  // the newest STATE's timestamp (callbacks; kept across sessions)
  std::uint64_t handed_ = 0;   // messages given to mosquitto_publish
  std::uint64_t written_ = 0;  // of them written out (on_publish: QoS 0)
  bool refused_logged_ = false;
  int failure_logged_ = 0;  // the reason last logged for a CONNECT that failed (MOSQ_ERR_*)
};

// The "online" member of a Sparkplug 3.0 STATE payload ({"online": true,
// "timestamp": ...}, spec 5: tck-id-host-topic-phid-birth-payload): 1, 0, or
// -1 when the text holds no boolean "online".
[[nodiscard]] int parse_state_online(std::string_view json) noexcept;
// Its "timestamp" member (ms since the epoch), or -1 when it holds none: a
// STATE older than the last one heard is stale (a late retained message or
// a host's previous session) and is not followed.
[[nodiscard]] std::int64_t parse_state_timestamp(std::string_view json) noexcept;

// The bdSeq metric of an NBIRTH or NDEATH payload (spec 6.4.x bdSeq); -1 if none.
[[nodiscard]] int payload_bd_seq(const std::uint8_t* data, std::size_t len) noexcept;

// Whether an NCMD payload asks for a rebirth: a metric named Node
// Control/Rebirth (or its alias) with boolean true (spec 6.4.x NCMD).
[[nodiscard]] bool ncmd_requests_rebirth(const std::uint8_t* data, std::size_t len) noexcept;

}  // namespace cobridge::mqtt
