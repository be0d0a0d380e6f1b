#include "mosquitto_link.hpp"

#include "edge_session.hpp"

#include <mosquitto.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <mutex>

namespace cobridge::mqtt {
namespace {

// mosquitto_lib_init once per process, before the first client (the daemon
// may load the plugin more than once over reloads).
void lib_init_once() {
  static std::once_flag once;
  std::call_once(once, [] { mosquitto_lib_init(); });
}

std::string mosq_error(int rc) { return mosquitto_strerror(rc); }

}  // namespace

namespace {

// What follows `"key":` in a flat JSON object (blanks skipped); empty when absent.
std::string_view json_member(std::string_view json, std::string_view quoted_key) noexcept {
  const auto blank = [&](std::size_t i) {
    return i < json.size() && (json[i] == ' ' || json[i] == '\t' || json[i] == '\n' || json[i] == '\r');
  };
  const std::size_t key = json.find(quoted_key);
  if (key == std::string_view::npos) return {};
  std::size_t i = key + quoted_key.size();
  while (blank(i)) ++i;
  if (i >= json.size() || json[i] != ':') return {};
  ++i;
  while (blank(i)) ++i;
  return json.substr(i);
}

}  // namespace

int parse_state_online(std::string_view json) noexcept {
  const std::string_view rest = json_member(json, "\"online\"");
  if (rest.starts_with("true")) return 1;
  if (rest.starts_with("false")) return 0;
  return -1;
}

std::int64_t parse_state_timestamp(std::string_view json) noexcept {
  const std::string_view rest = json_member(json, "\"timestamp\"");
  std::int64_t v = 0;
  std::size_t i = 0;
  for (; i < rest.size() && i < 18 && rest[i] >= '0' && rest[i] <= '9'; ++i) v = v * 10 + (rest[i] - '0');
  return i == 0 ? -1 : v;
}

int payload_bd_seq(const std::uint8_t* data, std::size_t len) noexcept {
  PbPayload* p = org__eclipse__tahu__protobuf__payload__unpack(nullptr, len, data);
  if (p == nullptr) return -1;
  int bd = -1;
  for (std::size_t i = 0; i < p->n_metrics; ++i) {
    const PbMetric* m = p->metrics[i];
    if (m->name != nullptr && std::strcmp(m->name, kBdSeqName) == 0 &&
        m->value_case == ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__METRIC__VALUE_LONG_VALUE)
      bd = static_cast<int>(m->long_value & 0xFFu);
  }
  org__eclipse__tahu__protobuf__payload__free_unpacked(p, nullptr);
  return bd;
}

bool ncmd_requests_rebirth(const std::uint8_t* data, std::size_t len) noexcept {
  PbPayload* p = org__eclipse__tahu__protobuf__payload__unpack(nullptr, len, data);
  if (p == nullptr) return false;
  bool rebirth = false;
  for (std::size_t i = 0; i < p->n_metrics; ++i) {
    const PbMetric* m = p->metrics[i];
    const bool named = (m->name != nullptr && std::strcmp(m->name, kRebirthName) == 0) ||
                       (m->has_alias != 0 && m->alias == kRebirthAlias);
    if (named && m->value_case == ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__METRIC__VALUE_BOOLEAN_VALUE &&
        m->boolean_value != 0)
      rebirth = true;
  }
  org__eclipse__tahu__protobuf__payload__free_unpacked(p, nullptr);
  return rebirth;
}

MosquittoLink::MosquittoLink(const MqttConfig& config, BdSeqFile& bd_seq, LogFn log)
    : config_(config), bd_file_(bd_seq), log_(std::move(log)) {
  ndeath_topic_ = sparkplug_topic(config_.group_id, "NDEATH", config_.edge_node_id);
  ncmd_topic_ = sparkplug_topic(config_.group_id, "NCMD", config_.edge_node_id);
  nbirth_topic_ = sparkplug_topic(config_.group_id, "NBIRTH", config_.edge_node_id);
  dcmd_prefix_ = sparkplug_topic(config_.group_id, "DCMD", config_.edge_node_id) + "/";
  if (!config_.primary_host_id.empty()) state_topic_ = "spBv1.0/STATE/" + config_.primary_host_id;
}

MosquittoLink::~MosquittoLink() { stop(); }

void MosquittoLink::set_will() {
  std::array<std::uint8_t, 128> buf{};
  const std::size_t n = encode_ndeath(will_builder_, bd_seq_.load(std::memory_order_relaxed), wall_ms(), buf);
  const int rc = mosquitto_will_set(mosq_, ndeath_topic_.c_str(), static_cast<int>(n), buf.data(), 1, false);
  if (rc != MOSQ_ERR_SUCCESS) log_(COBRIDGE_LOG_ERROR, "cannot set the NDEATH will: " + mosq_error(rc));
}

// Callbacks, credentials and TLS of a new client.
plugin::Error MosquittoLink::configure_client() {
  mosquitto_connect_callback_set(mosq_, &MosquittoLink::on_connect);
  mosquitto_disconnect_callback_set(mosq_, &MosquittoLink::on_disconnect);
  mosquitto_message_callback_set(mosq_, &MosquittoLink::on_message);
  mosquitto_publish_callback_set(mosq_, &MosquittoLink::on_publish);
  mosquitto_log_callback_set(mosq_, &MosquittoLink::on_log);
  mosquitto_reconnect_delay_set(mosq_, 1, 30, true);
  // Small messages one after another: without it Nagle's algorithm held
  // each DBIRTH behind the NBIRTH's unacknowledged segment for ~40 ms.
  (void)mosquitto_int_option(mosq_, MOSQ_OPT_TCP_NODELAY, 1);
  int rc = MOSQ_ERR_SUCCESS;
  if (!config_.username.empty()) {
    rc = mosquitto_username_pw_set(mosq_, config_.username.c_str(),
                                   config_.password.empty() ? nullptr : config_.password.c_str());
    if (rc != MOSQ_ERR_SUCCESS) return {std::error_code(rc, std::generic_category()), "username: " + mosq_error(rc)};
  }
  if (config_.tls()) {
    rc = mosquitto_tls_set(mosq_, config_.ca_file.c_str(), nullptr,
                           config_.cert_file.empty() ? nullptr : config_.cert_file.c_str(),
                           config_.key_file.empty() ? nullptr : config_.key_file.c_str(), nullptr);
    if (rc != MOSQ_ERR_SUCCESS) return {std::error_code(rc, std::generic_category()), "TLS: " + mosq_error(rc)};
  }
  return {};
}

plugin::Error MosquittoLink::start(std::optional<std::uint8_t> after, Mode mode) {
  lib_init_once();
  mode_ = mode;
  seen_bd_seq_.store(-1, std::memory_order_release);
  seen_dead_.store(false, std::memory_order_release);
  mosq_ = mosquitto_new(config_.client_id.c_str(), true, this);  // clean session (spec 5: tck-id-principles-persistence-clean-session-311)
  if (mosq_ == nullptr) return {std::error_code(errno, std::generic_category()), "mosquitto_new failed"};
  if (plugin::Error e = configure_client()) return e;
  // An observer carries no will: its loss is no death of the edge node.
  if (mode_ == Mode::kPublish) {
    bd_seq_.store(bd_file_.next(after), std::memory_order_release);
    set_will();
  }
  retry_delay_ = std::chrono::seconds(1);
  const int rc = connect(std::chrono::steady_clock::now());
  if (rc != MOSQ_ERR_SUCCESS)
    log_(COBRIDGE_LOG_WARN, "MQTT broker " + config_.host + ":" + std::to_string(config_.port) +
                                " not reached yet (" + mosq_error(rc) + "); retrying every 1 s to 30 s");
  return {};
}

// A CONNECT (asynchronous: the CONNACK arrives in service()); when it
// fails at once, the next one is due after the backoff.
int MosquittoLink::connect(std::chrono::steady_clock::time_point now) {
  const int rc = mosquitto_connect_async(mosq_, config_.host.c_str(), config_.port, static_cast<int>(config_.keepalive_s));
  socket_open_ = rc == MOSQ_ERR_SUCCESS && mosquitto_socket(mosq_) >= 0;
  if (!socket_open_) connect_later(now);
  return rc;
}

void MosquittoLink::connect_later(std::chrono::steady_clock::time_point now) {
  retry_at_ = now + retry_delay_;
  retry_delay_ = std::min(retry_delay_ * 2, std::chrono::seconds(30));
}

void MosquittoLink::service(std::chrono::steady_clock::time_point now) {
  if (mosq_ == nullptr) return;
  if (!socket_open_) {
    if (now >= retry_at_) (void)connect(now);
    return;
  }
  // Reads and keepalive can wait kLoopPeriod; writes and a CONNACK not.
  const bool pressing = mosquitto_want_write(mosq_) || !connected_.load(std::memory_order_relaxed);
  if (!pressing && now < next_loop_) return;
  next_loop_ = now + kLoopPeriod;
  // No wait (timeout 0); a lost socket has been closed and on_disconnect run.
  const int rc = mosquitto_loop(mosq_, 0, 1);
  if (mosquitto_socket(mosq_) >= 0) return;
  socket_open_ = false;
  connect_later(now);
  // A CONNECT that ended before its CONNACK (TLS refused, connection
  // refused, reset): said once per reason until a session comes up.
  if (!connected_.load(std::memory_order_relaxed) && rc != MOSQ_ERR_SUCCESS && rc != failure_logged_) {
    failure_logged_ = rc;
    log_(COBRIDGE_LOG_WARN, "MQTT broker " + config_.host + ":" + std::to_string(config_.port) +
                                " not reached (" + mosq_error(rc) + "); retrying every 1 s to 30 s");
  }
}

bool MosquittoLink::wants_write() const noexcept { return mosq_ != nullptr && mosquitto_want_write(mosq_); }

// Writes what waits for the socket (an NDEATH, the DISCONNECT), for at most `limit`.
void MosquittoLink::flush(std::chrono::milliseconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (mosquitto_socket(mosq_) >= 0 && mosquitto_want_write(mosq_) && std::chrono::steady_clock::now() < end)
    (void)mosquitto_loop(mosq_, 10, 1);
}

void MosquittoLink::stop() {
  if (mosq_ == nullptr) return;
  if (mode_ == Mode::kPublish && connected_.load(std::memory_order_acquire)) {
    std::array<std::uint8_t, 128> buf{};
    const std::size_t n = encode_ndeath(will_builder_, bd_seq_.load(std::memory_order_relaxed), wall_ms(), buf);
    (void)mosquitto_publish(mosq_, nullptr, ndeath_topic_.c_str(), static_cast<int>(n), buf.data(), 0, false);
  }
  // Written before the socket closes: a broker that sees the connection end
  // without DISCONNECT publishes the will, a second NDEATH.
  mosquitto_disconnect(mosq_);
  flush(std::chrono::milliseconds(500));
  mosquitto_destroy(mosq_);
  mosq_ = nullptr;
  socket_open_ = false;
  connected_.store(false, std::memory_order_release);
}

bool MosquittoLink::publish(const std::string& topic, std::span<const std::uint8_t> payload) {
  if (!connected_.load(std::memory_order_relaxed)) return false;
  if (handed_ > written_ && handed_ - written_ >= kMaxQueued) return false;
  // Counted before the call: on_publish runs inside it when the socket takes the packet.
  ++handed_;
  const int rc =
      mosquitto_publish(mosq_, nullptr, topic.c_str(), static_cast<int>(payload.size()), payload.data(), 0, false);
  // A failed write (connection lost, reset) left the packet queued: still
  // handed, and on_publish may count it later; the session's loss shows in
  // the next service(). Any other refusal queued nothing.
  if (rc != MOSQ_ERR_SUCCESS && rc != MOSQ_ERR_CONN_LOST && rc != MOSQ_ERR_ERRNO) --handed_;
  return rc == MOSQ_ERR_SUCCESS;
}

void MosquittoLink::on_publish(struct mosquitto*, void* self, int) { ++static_cast<MosquittoLink*>(self)->written_; }

MosquittoLink::State MosquittoLink::state() const noexcept {
  State s;
  s.generation = generation_.load(std::memory_order_acquire);
  s.connected = connected_.load(std::memory_order_acquire);
  s.observing = mode_ == Mode::kObserve;
  s.bd_seq = bd_seq_.load(std::memory_order_acquire);
  return s;
}

void MosquittoLink::on_connect(struct mosquitto* m, void* self, int rc) {
  auto* l = static_cast<MosquittoLink*>(self);
  if (rc != 0) {
    if (!l->refused_logged_) l->log_(COBRIDGE_LOG_ERROR, std::string("MQTT broker refused the connection: ") + mosquitto_connack_string(rc));
    l->refused_logged_ = true;
    return;
  }
  l->refused_logged_ = false;
  l->failure_logged_ = MOSQ_ERR_SUCCESS;
  mosquitto_log_callback_set(m, nullptr);  // set again when the session ends
  l->retry_delay_ = std::chrono::seconds(1);
  // libmosquitto dropped what a lost session had queued: nothing waits now.
  l->written_ = l->handed_;
  l->subscribe_all(m);
  l->connected_.store(true, std::memory_order_release);
  l->generation_.fetch_add(1, std::memory_order_acq_rel);
  const std::string node = l->config_.group_id + "/" + l->config_.edge_node_id;
  l->log_(COBRIDGE_LOG_INFO, "MQTT connected to " + l->config_.host + ":" + std::to_string(l->config_.port) +
                                 (l->mode_ == Mode::kObserve
                                      ? " as the standby of edge node " + node + " (publishing nothing)"
                                      : " as edge node " + node + " (bdSeq " + std::to_string(l->bd_seq_.load()) + ")"));
}

// The session is gone: the broker has published (or will publish) the
// will with this bdSeq, so the next CONNECT carries the next one.
// A session subscribes to its commands; an observer to the edge node's births and deaths.
void MosquittoLink::subscribe_all(struct mosquitto* m) {
  if (mode_ == Mode::kObserve) {
    (void)mosquitto_subscribe(m, nullptr, nbirth_topic_.c_str(), 0);
    (void)mosquitto_subscribe(m, nullptr, ndeath_topic_.c_str(), 0);
    return;
  }
  (void)mosquitto_subscribe(m, nullptr, ncmd_topic_.c_str(), 1);
  (void)mosquitto_subscribe(m, nullptr, (dcmd_prefix_ + "+").c_str(), 1);
  if (!state_topic_.empty()) (void)mosquitto_subscribe(m, nullptr, state_topic_.c_str(), 1);
}

void MosquittoLink::on_disconnect(struct mosquitto* m, void* self, int rc) {
  auto* l = static_cast<MosquittoLink*>(self);
  mosquitto_log_callback_set(m, &MosquittoLink::on_log);
  const bool was = l->connected_.exchange(false, std::memory_order_acq_rel);
  if (rc != 0 && l->mode_ == Mode::kPublish)
    l->bd_seq_.store(l->bd_file_.next(), std::memory_order_release);  // the next CONNECT's
  l->primary_.store(-1, std::memory_order_release);  // heard again (retained) after the reconnect
  if (was) l->generation_.fetch_add(1, std::memory_order_acq_rel);
  if (rc != 0) {
    if (was) l->log_(COBRIDGE_LOG_WARN, "MQTT connection lost (" + mosq_error(rc) + "); reconnecting");
    if (l->mode_ == Mode::kPublish) l->set_will();
  }
}

// libmosquitto's own errors (the OpenSSL reason of a refused TLS handshake,
// which its return codes do not carry); its notices and debug lines are not
// kept. Set only while no session is up: with a log callback set,
// libmosquitto formats a debug line (malloc, vsnprintf) for every PUBLISH.
void MosquittoLink::on_log(struct mosquitto*, void* self, int level, const char* text) {
  if ((level & (MOSQ_LOG_ERR | MOSQ_LOG_WARNING)) == 0 || text == nullptr) return;
  static_cast<MosquittoLink*>(self)->log_(COBRIDGE_LOG_WARN, std::string("MQTT client: ") + text);
}

void MosquittoLink::on_message(struct mosquitto*, void* self, const struct mosquitto_message* msg) {
  auto* l = static_cast<MosquittoLink*>(self);
  if (msg == nullptr || msg->topic == nullptr) return;
  const std::string_view topic(msg->topic);
  if (l->mode_ == Mode::kObserve) {
    if (topic != l->nbirth_topic_ && topic != l->ndeath_topic_) return;
    const int bd = payload_bd_seq(static_cast<const std::uint8_t*>(msg->payload),
                                  msg->payloadlen > 0 ? static_cast<std::size_t>(msg->payloadlen) : 0u);
    if (bd >= 0) l->seen_bd_seq_.store(bd, std::memory_order_release);
    l->seen_dead_.store(topic == l->ndeath_topic_, std::memory_order_release);
    return;
  }
  if (l->ncmd_topic_ == topic) {
    l->handle_ncmd(msg->payload, msg->payloadlen);
  } else if (topic.starts_with(l->dcmd_prefix_)) {
    l->handle_dcmd(topic.substr(l->dcmd_prefix_.size()), msg->payload, msg->payloadlen);
  } else if (!l->state_topic_.empty() && l->state_topic_ == msg->topic) {
    l->handle_state(std::string_view(static_cast<const char*>(msg->payload),
                                     msg->payloadlen > 0 ? static_cast<std::size_t>(msg->payloadlen) : 0u));
  }
}

void MosquittoLink::handle_dcmd(std::string_view device_id, const void* payload, int len) {
  const DcmdRequest r = parse_dcmd(device_id, static_cast<const std::uint8_t*>(payload),
                                   len > 0 ? static_cast<std::size_t>(len) : 0u);
  if (!dcmds_.try_push(r))
    log_(COBRIDGE_LOG_WARN, "DCMD for device " + std::string(device_id) + " dropped: 64 DCMDs wait already");
}

void MosquittoLink::handle_state(std::string_view text) {
  const int online = parse_state_online(text);
  if (online < 0) {
    log_(COBRIDGE_LOG_WARN, "STATE of primary host " + config_.primary_host_id + " ignored: no boolean \"online\"");
    return;
  }
  const std::int64_t stamp = parse_state_timestamp(text);
  if (stamp >= 0 && stamp < state_stamp_) {
    log_(COBRIDGE_LOG_INFO, "STATE of primary host " + config_.primary_host_id + " ignored: its timestamp " +
                                std::to_string(stamp) + " is older than the last one heard (" +
                                std::to_string(state_stamp_) + ")");
    return;
  }
  if (stamp >= 0) state_stamp_ = stamp;
  primary_.store(online, std::memory_order_release);
}

void MosquittoLink::handle_ncmd(const void* payload, int len) {
  if (len <= 0) return;
  if (ncmd_requests_rebirth(static_cast<const std::uint8_t*>(payload), static_cast<std::size_t>(len))) {
    log_(COBRIDGE_LOG_INFO, "NCMD Node Control/Rebirth: publishing NBIRTH and every DBIRTH again");
    rebirth_.store(true, std::memory_order_release);
  }
}

}  // namespace cobridge::mqtt
