#include "dds/gateway_presence.hpp"

#include "dds/dds_publisher.hpp"
#include "dds/topics.hpp"

#include <unistd.h>

#include <array>
#include <chrono>
#include <random>

namespace cobridge::dds {
namespace {

std::uint64_t realtime_ns() noexcept {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
          .count());
}

std::string host_name() {
  std::array<char, 256> buf{};
  if (::gethostname(buf.data(), buf.size() - 1) != 0) return "?";
  return buf.data();
}

// Random per start, so that a restarted gateway (same host, maybe same pid
// in a container) is told apart from a second one.
std::uint64_t new_incarnation() {
  std::random_device rd;
  const std::uint64_t r = (static_cast<std::uint64_t>(rd()) << 32) ^ rd();
  return r ^ realtime_ns();
}

// One bus of GatewayStatus.bus_health; the strings point into `b`.
cobridge_BusHealth to_idl(const BusHealthEntry& b) noexcept {
  cobridge_BusHealth h{};
  h.bus_index = b.bus_index;
  h.bus_name = const_cast<char*>(b.bus_name.c_str());
  h.open = b.open;
  h.controller_state = b.controller_state;
  h.source = const_cast<char*>(b.source.c_str());
  h.counters_known = b.counters_known;
  h.tx_errors = b.tx_errors;
  h.rx_errors = b.rx_errors;
  h.restarts = b.restarts;
  h.error_frames = b.error_frames;
  h.since_ns = b.since_ns;
  return h;
}

// Reader take size; the same on every take (see docs/dds.md, the loan quirk).
constexpr std::uint32_t kTake = 16;

}  // namespace

GatewayPresence::GatewayPresence(const GatewayName& gateway, std::string topic_prefix, std::string partition,
                                 dds_duration_t lease)
    : gateway_(gateway), topic_prefix_(std::move(topic_prefix)), partition_(std::move(partition)), lease_(lease) {}

GatewayPresence::~GatewayPresence() { stop(); }

plugin::Error GatewayPresence::start(dds_entity_t participant) {
  host_ = host_name();
  pid_ = static_cast<std::uint32_t>(::getpid());
  incarnation_ = new_incarnation();
  started_ns_ = realtime_ns();
  const std::string name = topic_name(topic_prefix_, kGatewayStatusTopic);
  topic_ = dds_create_topic(participant, &cobridge_GatewayStatus_desc, name.c_str(), nullptr, nullptr);
  if (topic_ < 0) {
    plugin::Error e(make_dds_error(topic_), "cannot create topic '" + name + "': " + dds_strretcode(topic_));
    topic_ = 0;
    return e;
  }
  publisher_ = dds_create_publisher(participant, partition_qos(partition_).get(), nullptr);
  subscriber_ = dds_create_subscriber(participant, partition_qos(partition_).get(), nullptr);
  if (publisher_ < 0 || subscriber_ < 0) {
    const dds_return_t rc = publisher_ < 0 ? publisher_ : subscriber_;
    if (publisher_ < 0) publisher_ = 0;
    if (subscriber_ < 0) subscriber_ = 0;
    stop();
    return {make_dds_error(rc),
            "cannot create a DDS publisher/subscriber for partition '" + partition_ + "': " + dds_strretcode(rc)};
  }
  writer_ = dds_create_writer(publisher_, topic_, gateway_status_writer_qos(lease_).get(), nullptr);
  reader_ = writer_ > 0 ? dds_create_reader(subscriber_, topic_, gateway_status_reader_qos().get(), nullptr) : 0;
  if (writer_ < 0 || reader_ < 0) {
    const dds_return_t rc = writer_ < 0 ? writer_ : reader_;
    const std::string what = writer_ < 0 ? "writer" : "reader";
    if (writer_ < 0) writer_ = 0;
    if (reader_ < 0) reader_ = 0;
    stop();
    return {make_dds_error(rc), "cannot create the " + what + " of '" + name + "': " + dds_strretcode(rc)};
  }
  publish(counts_, pair_, buses_, true);
  return {};
}

void GatewayPresence::stop() noexcept {
  if (writer_ > 0 && ever_written_) {
    cobridge_GatewayStatus key{};
    key.gateway_key = gateway_.key;
    key.gateway_id = const_cast<char*>(gateway_.id);
    key.host = key.duplicate_of = key.role = key.election_cause = const_cast<char*>("");
    (void)dds_dispose(writer_, &key);
    (void)dds_write_flush(writer_);  // the domain may batch writes (write_batch)
  }
  if (reader_ > 0) (void)dds_delete(reader_);
  if (writer_ > 0) (void)dds_delete(writer_);
  if (publisher_ > 0) (void)dds_delete(publisher_);
  if (subscriber_ > 0) (void)dds_delete(subscriber_);
  if (topic_ > 0) (void)dds_delete(topic_);
  reader_ = writer_ = topic_ = publisher_ = subscriber_ = 0;
  ever_written_ = false;
}

DuplicateChange GatewayPresence::poll() noexcept {
  if (reader_ <= 0) return DuplicateChange::kNone;
  const bool before = duplicate();
  try {
    for (;;) {
      void* buf[kTake] = {};
      dds_sample_info_t info[kTake];
      const int n = dds_take(reader_, buf, info, kTake, kTake);
      if (n <= 0) break;
      for (int i = 0; i < n; ++i) {
        const auto& s = *static_cast<const cobridge_GatewayStatus*>(buf[i]);
        if (s.gateway_key != gateway_.key) continue;  // another gateway: fine
        if (info[i].valid_data && s.incarnation != incarnation_ && info[i].instance_state == DDS_IST_ALIVE) {
          duplicate_of_ = std::string(s.host != nullptr ? s.host : "?") + " pid " + std::to_string(s.pid);
        } else if (info[i].instance_state != DDS_IST_ALIVE) {
          duplicate_of_.clear();  // the other one stopped (disposed) or died (no writers)
        }
      }
      (void)dds_return_loan(reader_, buf, n);
      if (n < static_cast<int>(kTake)) break;
    }
  } catch (...) {
    // std::string out of memory: keep what is known.
  }
  if (duplicate() == before) return DuplicateChange::kNone;
  return duplicate() ? DuplicateChange::kDetected : DuplicateChange::kGone;
}

void GatewayPresence::set_pair_node(std::uint8_t node) {
  if (node == 0) return;
  gateway_.key = gateway_key(std::string(gateway_.id) + "#" + std::to_string(node));
  pair_.node = node;
}

void GatewayPresence::publish(const GatewayCounts& counts, const PairStatus& pair,
                              const std::vector<BusHealthEntry>& buses, bool force) noexcept {
  if (writer_ <= 0) return;
  if (!force && ever_written_ && counts == counts_ && pair == pair_ && buses == buses_ &&
      duplicate() == written_duplicate_)
    return;
  counts_ = counts;
  try {
    pair_ = pair;
    buses_ = buses;
  } catch (...) {
    // std::string out of memory: the last role and health are written again.
  }
  write(realtime_ns());
}

void GatewayPresence::write(std::uint64_t now_ns) noexcept {
  cobridge_GatewayStatus st{};
  st.gateway_key = gateway_.key;
  st.gateway_id = const_cast<char*>(gateway_.id);
  st.host = const_cast<char*>(host_.c_str());
  st.pid = pid_;
  st.incarnation = incarnation_;
  st.started_ns = started_ns_;
  st.devices = counts_.devices;
  st.devices_online = counts_.devices_online;
  st.buses = counts_.buses;
  st.buses_online = counts_.buses_online;
  st.duplicate_id = duplicate();
  st.duplicate_of = const_cast<char*>(duplicate_of_.c_str());
  st.updated_ns = now_ns;
  st.redundancy_node = pair_.node;
  st.role = const_cast<char*>(pair_.role.c_str());
  st.master_node = pair_.master_node;
  st.peer_node = pair_.peer_node;
  st.election_cause = const_cast<char*>(pair_.cause.c_str());
  st.election_ns = pair_.since_ns;
  // The sequence points into buses_ for the write only (Cyclone copies it).
  std::vector<cobridge_BusHealth> health;
  try {
    health.reserve(buses_.size());
  } catch (...) {
    // Out of memory: written without bus_health this time.
  }
  for (const BusHealthEntry& b : buses_) {
    if (health.size() == health.capacity()) break;
    health.push_back(to_idl(b));
  }
  st.bus_health._length = st.bus_health._maximum = static_cast<std::uint32_t>(health.size());
  st.bus_health._buffer = health.data();
  st.bus_health._release = false;
  if (dds_write(writer_, &st) == DDS_RETCODE_OK) ++writes_;
  (void)dds_write_flush(writer_);  // the domain may batch writes (write_batch)
  written_duplicate_ = duplicate();
  ever_written_ = true;
}

}  // namespace cobridge::dds
