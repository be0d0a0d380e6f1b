#include "edge_session.hpp"

#include <chrono>
#include <cmath>
#include <cstdlib>

namespace cobridge::mqtt {
namespace {

// A DBIRTH of 21 metrics with short strings is < 2 KiB; 16 KiB leaves room
// for long names and units without a second allocation.
constexpr std::size_t kBufferBytes = 16 * 1024;

// Sparkplug device ids may not hold '/', '+' or '#' (spec 4.1.1): replaced.
std::string device_id_of(const DeviceRecord& r) {
  std::string id = r.name[0] != '\0' ? std::string(r.name) : "node" + std::to_string(r.node_id);
  for (char& c : id)
    if (c == '/' || c == '+' || c == '#') c = '_';
  return id;
}

std::uint64_t ns_to_ms(std::uint64_t ns) noexcept { return ns / 1'000'000u; }

}  // namespace

std::uint64_t wall_ms() noexcept {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
          .count());
}

std::string sparkplug_topic(const std::string& group, const char* type, const std::string& edge,
                            const std::string& device) {
  std::string t = "spBv1.0/" + group + "/" + type + "/" + edge;
  if (!device.empty()) t += "/" + device;
  return t;
}

std::size_t encode_ndeath(PayloadBuilder& b, std::uint8_t bd_seq, std::uint64_t now_ms,
                          std::span<std::uint8_t> out) noexcept {
  b.begin(now_ms, std::nullopt);
  if (!b.add_scalar(kBdSeqName, 0, now_ms, DataType::kInt64, Scalar{bd_seq, 0.0})) return 0;
  return b.pack(out);
}

EdgeSession::EdgeSession(Ids ids, const std::array<double, 16>& deadband, Publisher& out)
    : ids_(std::move(ids)), deadband_(deadband), out_(out), buffer_(kBufferBytes) {
  nbirth_topic_ = sparkplug_topic(ids_.group_id, "NBIRTH", ids_.edge_node_id);
}

void EdgeSession::set_link(bool up, std::uint8_t bd_seq, std::uint64_t now_ms) {
  flush();  // the old session's last DDATA (on a lost link: counted as drops)
  link_up_ = up;
  bd_seq_ = bd_seq;
  node_born_ = false;  // a new MQTT session is a new Sparkplug session: births again
  for (Device& d : devices_) d.born = false;
  update_liveness(now_ms);
}

void EdgeSession::set_primary_online(bool online, std::uint64_t now_ms) {
  if (online == primary_online_) return;
  flush();
  primary_online_ = online;
  update_liveness(now_ms);
}

void EdgeSession::rebirth(std::uint64_t now_ms) {
  if (!live()) return;
  flush();
  births(now_ms);
}

// Births when publishing becomes allowed; everything unborn when it stops
// (so that the next allowed moment starts with NBIRTH again).
void EdgeSession::update_liveness(std::uint64_t now_ms) {
  if (live()) {
    if (!node_born_) births(now_ms);
    return;
  }
  node_born_ = false;
  for (Device& d : devices_) d.born = false;
}

void EdgeSession::births(std::uint64_t now_ms) {
  seq_ = 0;
  publish_nbirth(now_ms);
  node_born_ = true;
  for (Device& d : devices_)
    if (d.known && d.heard != Heard::kOffline) publish_dbirth(d, now_ms);
  // Store and forward: history after the births (a host learns the aliases first).
  for (Device& d : devices_)
    if (d.born) replay(d, now_ms);
}

// What changed beyond the deadband since the last sent (or stored or
// batched) value: into `out`, and taken as sent.
std::size_t EdgeSession::take_changed(Device& d, std::span<const Reading> readings,
                                      std::span<Reading, kProcess> out) noexcept {
  std::size_t n = 0;
  for (const Reading& r : readings) {
    if (n == out.size() || !worth_sending(d, r)) continue;
    out[n++] = r;
    const std::size_t k = process_index(r.id);
    d.sent[k] = r.value;
    d.has_sent[k] = true;
  }
  return n;
}

// What DDATA would have carried goes into the history.
void EdgeSession::store(Device& d, std::span<const Reading> readings, std::uint64_t ts_ms) {
  std::array<Reading, kProcess> changed{};
  const std::size_t n = take_changed(d, readings, changed);
  if (n == 0) return;
  const std::size_t dropped = d.history.push(ts_ms, std::span<const Reading>(changed.data(), n));
  counters_.stored.fetch_add(1, std::memory_order_relaxed);
  if (dropped != 0) counters_.store_drops.fetch_add(dropped, std::memory_order_relaxed);
}

// What DDATA would carry now waits in the device's batch for flush(); a
// full batch goes out first.
void EdgeSession::queue_ddata(Device& d, std::span<const Reading> readings, std::uint64_t ts_ms) {
  std::array<Reading, kProcess> changed{};
  const std::size_t n = take_changed(d, readings, changed);
  if (n == 0) return;
  if (d.batch.size() == d.batch.capacity()) flush_device(d);
  if (d.batch.size() == 0) ++batched_devices_;
  (void)d.batch.push(ts_ms, std::span<const Reading>(changed.data(), n));
}

void EdgeSession::flush_device(Device& d) {
  if (d.batch.size() == 0) return;
  --batched_devices_;
  publish_entries(d, d.batch, false, d.batch.at(d.batch.size() - 1).ts_ms);
  d.batch.clear();
}

void EdgeSession::flush() {
  for (std::size_t i = 0; i < devices_.size() && batched_devices_ != 0; ++i) flush_device(devices_[i]);
}

void EdgeSession::flush_entries(Device& d) {
  if (builder_.metric_count() == 0) return;
  builder_.set_seq(next_seq());
  send(d.ddata, false);
}

// Entries as DDATA, oldest first, each metric with its frame's time (and
// is_historical for the history: spec 5, store and forward); as many
// metrics per message as fit.
void EdgeSession::publish_entries(Device& d, const HistoryBuffer& entries, bool historical, std::uint64_t payload_ms) {
  builder_.begin(payload_ms, std::nullopt);
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const HistoryBuffer::Entry& e = entries.at(i);
    if (builder_.metric_count() + e.count > PayloadBuilder::kMaxMetrics) {
      flush_entries(d);
      builder_.begin(payload_ms, std::nullopt);
    }
    for (std::size_t j = 0; j < e.count; ++j) {
      const MetricDef* m = find_metric(e.ids[j]);
      (void)builder_.add_scalar(nullptr, device_alias(d.info.device_index, e.ids[j]), e.ts_ms, m->type,
                                e.values[j]);
      if (historical) builder_.mark_historical();
    }
  }
  flush_entries(d);
}

void EdgeSession::replay(Device& d, std::uint64_t now_ms) {
  const std::size_t n = d.history.size();
  if (n == 0) return;
  publish_entries(d, d.history, true, now_ms);
  counters_.replayed.fetch_add(n, std::memory_order_relaxed);
  d.history.clear();
}

void EdgeSession::send(const std::string& topic, bool birth) {
  const std::size_t n = builder_.pack(buffer_);
  if (n == 0 || !out_.publish(topic, std::span<const std::uint8_t>(buffer_.data(), n))) {
    counters_.drops.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  counters_.messages.fetch_add(1, std::memory_order_relaxed);
  counters_.bytes.fetch_add(n, std::memory_order_relaxed);
  if (birth) counters_.births.fetch_add(1, std::memory_order_relaxed);
}

void EdgeSession::publish_nbirth(std::uint64_t now_ms) {
  builder_.begin(now_ms, next_seq());
  (void)builder_.add_scalar(kBdSeqName, 0, now_ms, DataType::kInt64, Scalar{bd_seq_, 0.0});
  (void)builder_.add_scalar(kRebirthName, kRebirthAlias, now_ms, DataType::kBoolean, Scalar{0, 0.0});
  send(nbirth_topic_, true);
}

void EdgeSession::add_identity(const Device& d, std::uint64_t now_ms) {
  const DeviceRecord& r = d.info;
  for (const MetricDef& m : identity_metrics()) {
    const std::uint64_t alias = device_alias(r.device_index, m.id);
    std::int64_t v = 0;
    const char* text = nullptr;
    switch (m.id) {
      case DeviceMetric::kVendorId: v = r.vendor_id; break;
      case DeviceMetric::kProductCode: v = r.product_code; break;
      case DeviceMetric::kRevision: v = r.revision; break;
      case DeviceMetric::kSerial: v = r.serial; break;
      case DeviceMetric::kNodeId: v = r.node_id; break;
      case DeviceMetric::kModel: text = r.model; break;
      case DeviceMetric::kFamily: text = r.family; break;
      default: text = r.bus_name; break;
    }
    if (m.type == DataType::kString) {
      (void)builder_.add_string(m.name, alias, now_ms, m.type, text);
    } else {
      (void)builder_.add_scalar(m.name, alias, now_ms, m.type, Scalar{v, 0.0});
    }
  }
}

// The command metrics a host may write (spec 6.4.x DCMD: only metrics the
// DBIRTH declared): the writable ones with a neutral value, the outcome ones null.
void EdgeSession::add_commands(const Device& d, std::uint64_t now_ms) {
  for (const MetricDef& m : command_metrics()) {
    const std::uint64_t alias = device_alias(d.info.device_index, m.id);
    const bool ok = m.type == DataType::kBoolean ? builder_.add_scalar(m.name, alias, now_ms, m.type, Scalar{})
                                                 : builder_.add_null(m.name, alias, now_ms, m.type);
    if (ok && m.unit[0] != '\0') (void)builder_.add_property("engUnit", m.unit);
  }
}

void EdgeSession::publish_result(const CommandResult& r, std::uint64_t now_ms) {
  if (r.device_index >= devices_.size() || !devices_[r.device_index].born || !live() || !node_born_) {
    counters_.drops.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  Device& d = devices_[r.device_index];
  flush_device(d);
  builder_.begin(now_ms, next_seq());
  (void)builder_.add_string(nullptr, device_alias(r.device_index, DeviceMetric::kCmdClient), now_ms,
                            DataType::kString, r.client.c_str());
  (void)builder_.add_string(nullptr, device_alias(r.device_index, DeviceMetric::kCmdResult), now_ms,
                            DataType::kString, r.text.c_str());
  (void)builder_.add_scalar(nullptr, device_alias(r.device_index, DeviceMetric::kCmdResultCode), now_ms,
                            DataType::kInt32, Scalar{r.code, 0.0});
  send(d.ddata, false);
}

int EdgeSession::device_index_of(std::string_view id) const noexcept {
  for (std::size_t i = 0; i < devices_.size(); ++i)
    if (devices_[i].known && devices_[i].device_id == id) return static_cast<int>(i);
  return -1;
}

const char* EdgeSession::device_name(std::uint16_t index) const noexcept {
  return index < devices_.size() ? devices_[index].info.name : "";
}

void EdgeSession::publish_dbirth(Device& d, std::uint64_t now_ms) {
  flush_device(d);  // its DDATA before its birth, in seq
  builder_.begin(now_ms, next_seq());
  for (const MetricDef& m : process_metrics()) {
    const std::size_t k = process_index(m.id);
    if (!in_metric_set(d, k)) continue;
    const std::uint64_t alias = device_alias(d.info.device_index, m.id);
    // Every metric DDATA may carry is in the DBIRTH (spec 6.4.x,
    // tck-id-payloads-dbirth-*): a value not heard yet is sent as null.
    const bool ok = d.has_last[k] ? builder_.add_scalar(m.name, alias, d.last_ms[k], m.type, d.last[k])
                                  : builder_.add_null(m.name, alias, now_ms, m.type);
    const char* unit = m.unit[0] == '*' ? d.info.position_unit : m.unit;
    if (ok && unit[0] != '\0') (void)builder_.add_property("engUnit", unit);
    d.sent[k] = d.last[k];
    d.has_sent[k] = d.has_last[k];
  }
  add_commands(d, now_ms);
  add_identity(d, now_ms);
  send(d.dbirth, true);
  d.born = true;
}

void EdgeSession::publish_ddeath(Device& d, std::uint64_t now_ms) {
  flush_device(d);  // its last DDATA before its death
  builder_.begin(now_ms, next_seq());
  send(d.ddeath, false);
  counters_.deaths.fetch_add(1, std::memory_order_relaxed);
  d.born = false;
}

void EdgeSession::on_device(const DeviceRecord& r, std::uint64_t now_ms) {
  if (r.device_index >= devices_.size()) devices_.resize(r.device_index + 1u);
  Device& d = devices_[r.device_index];
  if (r.change == COBRIDGE_DEVICE_REMOVED) {
    if (d.born && live()) publish_ddeath(d, now_ms);
    if (d.batch.size() != 0) --batched_devices_;
    d = Device{};
    return;
  }
  const bool renamed = !d.known || std::string_view(d.info.name) != std::string_view(r.name);
  if (renamed && d.born && live()) publish_ddeath(d, now_ms);  // the old device id dies
  if (!d.known) {  // once: off the hot path
    d.history.reset(ids_.store_capacity, ids_.store_window_ms);
    d.batch.reset(ids_.batch_samples, 0);
  }
  d.known = true;
  d.info = r;
  if (renamed) {
    d.metrics = ids_.metrics.for_device(r.name);
    d.device_id = device_id_of(r);
    d.dbirth = sparkplug_topic(ids_.group_id, "DBIRTH", ids_.edge_node_id, d.device_id);
    d.ddata = sparkplug_topic(ids_.group_id, "DDATA", ids_.edge_node_id, d.device_id);
    d.ddeath = sparkplug_topic(ids_.group_id, "DDEATH", ids_.edge_node_id, d.device_id);
  }
  // A changed identity is told by a new DBIRTH (spec: metrics' properties only change with a birth).
  if (live() && node_born_ && d.heard != Heard::kOffline) publish_dbirth(d, now_ms);
}

// The gateway's supervision decides life and death (STATUS samples); a
// device never told about is taken as alive by its first frame.
void EdgeSession::track_status(Device& d, const cobridge_sample& s, std::uint64_t now_ms) {
  if (s.kind == COBRIDGE_SAMPLE_STATUS && (s.valid & COBRIDGE_VALID_STATUS) != 0) {
    d.heard = s.online != 0 ? Heard::kOnline : Heard::kOffline;
    if (d.heard == Heard::kOffline && d.born && live()) publish_ddeath(d, now_ms);
  } else if (d.heard == Heard::kUnknown && s.kind != COBRIDGE_SAMPLE_COMMAND) {
    d.heard = Heard::kOnline;
  }
}

bool EdgeSession::worth_sending(const Device& d, const Reading& r) const noexcept {
  const std::size_t k = process_index(r.id);
  if (!in_metric_set(d, k)) return false;
  if (!d.has_sent[k]) return true;
  const MetricDef* m = find_metric(r.id);
  const bool real = m->type == DataType::kFloat || m->type == DataType::kDouble;
  const double diff = real ? std::fabs(r.value.d - d.sent[k].d)
                           : std::fabs(static_cast<double>(r.value.i - d.sent[k].i));
  return diff > 0.0 && diff >= deadband_[k];
}

void EdgeSession::publish_ddata(Device& d, std::span<const Reading> readings, std::uint64_t ts_ms) {
  builder_.begin(ts_ms, std::nullopt);  // seq taken only if something is sent
  for (const Reading& r : readings) {
    if (!worth_sending(d, r)) continue;
    const MetricDef* m = find_metric(r.id);
    // By alias only (spec 6.4.4: the name may be left out once the birth gave the alias).
    if (!builder_.add_scalar(nullptr, device_alias(d.info.device_index, r.id), ts_ms, m->type, r.value)) break;
    const std::size_t k = process_index(r.id);
    d.sent[k] = r.value;
    d.has_sent[k] = true;
  }
  if (builder_.metric_count() == 0) return;
  builder_.set_seq(next_seq());
  send(d.ddata, false);
}

void EdgeSession::on_sample(const cobridge_sample& s, std::uint64_t now_ms) {
  if (s.device_index >= devices_.size()) return;
  Device& d = devices_[s.device_index];
  if (!d.known) return;
  std::array<Reading, kProcess> readings{};
  const std::size_t n = extract(s, readings);
  const std::uint64_t ts_ms = ns_to_ms(s.rx_timestamp_ns);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t k = process_index(readings[i].id);
    d.last[k] = readings[i].value;
    d.last_ms[k] = ts_ms;
    d.has_last[k] = true;
  }
  const bool was_born = d.born;
  track_status(d, s, now_ms);
  if (!live() || !node_born_) {
    // Not published now: kept for store and forward when a store is configured.
    if (!active_) return;  // a standby: the master publishes these
    if (n != 0 && d.history.capacity() != 0 && d.heard != Heard::kOffline) {
      store(d, std::span<const Reading>(readings.data(), n), ts_ms);
    } else if (n != 0) {
      counters_.drops.fetch_add(1, std::memory_order_relaxed);
    }
    return;
  }
  if (d.heard == Heard::kOffline) return;
  if (!d.born) {
    publish_dbirth(d, now_ms);  // holds this sample's values
    replay(d, now_ms);          // what it had stored while the node could not publish
    return;
  }
  if (!was_born || n == 0) return;
  if (d.batch.capacity() != 0) {
    queue_ddata(d, std::span<const Reading>(readings.data(), n), ts_ms);
  } else {
    publish_ddata(d, std::span<const Reading>(readings.data(), n), ts_ms);
  }
}

}  // namespace cobridge::mqtt
