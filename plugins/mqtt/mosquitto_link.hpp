// MosquittoLink: the plugin's MQTT client on libmosquitto, in its threaded
// mode (mosquitto_loop_start: libmosquitto's own thread runs the socket,
// keepalive and reconnects). It owns what the MQTT session must carry for
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
// Thread contract: start/stop on the daemon's control thread; publish() and
// the poll functions from the plugin's publisher thread; the callbacks run
// on libmosquitto's thread and only touch atomics, the will and the log.
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
  // disconnects and joins the client thread.
  void stop();

  // Publisher thread, each pass: while the first CONNECT has not started
  // (it failed at once), tries it again when due (1 s, doubling to 30 s)
  // and on success starts libmosquitto's thread, which reconnects from
  // then on. Nothing to do otherwise.
  void retry_connect(std::chrono::steady_clock::time_point now);
  // Whether a first CONNECT waits for retry_connect() (tests, stats).
  [[nodiscard]] bool awaiting_first_connect() const noexcept { return mosq_ != nullptr && !loop_started_; }

  // Messages handed to libmosquitto and not yet written to the socket, at most.
  static constexpr std::uint64_t kMaxQueued = 4096;

  // QoS 0, not retained. False when not connected, kMaxQueued are waiting,
  // or the client refused it.
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

  void set_will();
  void handle_ncmd(const void* payload, int len);
  void handle_state(std::string_view text);
  void handle_dcmd(std::string_view topic, const void* payload, int len);
  void subscribe_all(struct mosquitto* m);
  [[nodiscard]] plugin::Error configure_client();
  [[nodiscard]] int connect_and_loop();

  const MqttConfig& config_;
  BdSeqFile& bd_file_;
  LogFn log_;
  struct mosquitto* mosq_ = nullptr;
  bool loop_started_ = false;
  // The first CONNECT's retry (start/stop/retry_connect: never at once).
  std::chrono::steady_clock::time_point retry_at_{};
  std::chrono::seconds retry_delay_{1};
  std::string ndeath_topic_;
  std::string ncmd_topic_;
  std::string state_topic_;
  std::string dcmd_prefix_;  // "spBv1.0/<group>/DCMD/<edge>/"
  std::string nbirth_topic_;
  Mode mode_ = Mode::kPublish;  // set by start() before the client thread runs
  std::atomic<int> seen_bd_seq_{-1};
  std::atomic<bool> seen_dead_{false};
  SpscRing<DcmdRequest> dcmds_{64};  // client thread -> publisher thread
  PayloadBuilder will_builder_;  // client thread (callbacks) and start/stop, never at once
  std::atomic<std::uint64_t> generation_{0};
  std::atomic<bool> connected_{false};
  std::atomic<std::uint8_t> bd_seq_{0};
  std::atomic<bool> rebirth_{false};
  std::atomic<int> primary_{-1};
  std::int64_t state_stamp_ = -1;  // the newest STATE's timestamp (callbacks; kept across sessions)
  std::atomic<std::uint64_t> handed_{0};   // publisher thread
  std::atomic<std::uint64_t> written_{0};  // client thread (on_publish: QoS 0 written out)
  bool refused_logged_ = false;  // client thread only
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
