#include "dds/dds_publisher.hpp"

#include "dds/pair_role.hpp"
#include "dds/dds_security.hpp"
#include "dds/sample_mapping.hpp"
#include "dds/topics.hpp"

#include <chrono>
#include <cstdlib>
#include <utility>

namespace cobridge::dds {
namespace {

class DdsCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "cyclonedds"; }
  std::string message(int c) const override { return dds_strretcode(-c); }
};

constexpr std::uint8_t kFlushSample = 1, kFlushEvent = 2, kFlushStatus = 4;

// Cyclone reads a configuration as a comma-separated list of XML fragments
// and files, later ones overriding earlier ones.
constexpr const char* kWriteBatchXml = "<Internal><WriteBatch>true</WriteBatch></Internal>";

std::uint64_t realtime_ns() noexcept {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
          .count());
}

}  // namespace

const std::error_category& dds_category() noexcept {
  static const DdsCategory category;
  return category;
}

// Cyclone's codes are negative; error_code wants them positive (0 = success).
std::error_code make_dds_error(dds_return_t rc) noexcept { return {rc < 0 ? -rc : rc, dds_category()}; }

DdsPublisher::DdsPublisher(DdsConfig config, std::string gateway_id)
    : config_(std::move(config)), gateway_id_(std::move(gateway_id)), gateway_{gateway_id_.c_str(), gateway_key(gateway_id_)} {}

DdsPublisher::~DdsPublisher() { stop(); }

plugin::Error DdsPublisher::start(std::string& note) {
  if (started()) return {};
  const auto domain = static_cast<dds_domainid_t>(config_.domain);
  if (config_.write_batch) {
    if (plugin::Error e = create_domain(domain, note)) return e;
  }
  if (plugin::Error e = create_participant(domain)) {
    stop();
    return e;
  }
  // Writers under a publisher of the configured partition.
  publisher_ = dds_create_publisher(participant_, partition_qos(config_.partition).get(), nullptr);
  if (publisher_ < 0) {
    const dds_return_t rc = publisher_;
    publisher_ = 0;
    stop();
    return {make_dds_error(rc),
            "cannot create a DDS publisher for partition '" + config_.partition + "': " + dds_strretcode(rc)};
  }
  if (plugin::Error e = create_writers()) {
    stop();
    return e;
  }
  // A restart re-announces what the plugin already knows.
  for (std::uint16_t i = 0; i < slots_.capacity(); ++i) {
    if (const DeviceSlot* slot = slots_.find(i); slot != nullptr && slot->in_use) write_status(*slot);
  }
  flush();
  return {};
}

// WriteBatch is a domain setting, and an explicitly created domain does not
// read CYCLONEDDS_URI by itself: pass it on after ours.
plugin::Error DdsPublisher::create_domain(dds_domainid_t domain, std::string& note) {
  std::string xml = kWriteBatchXml;
  if (const char* uri = std::getenv("CYCLONEDDS_URI"); uri != nullptr && *uri != '\0') {
    xml += ',';
    xml += uri;
  }
  const dds_entity_t d = dds_create_domain(domain, xml.c_str());
  if (d > 0) {
    domain_ = d;
  } else if (d == DDS_RETCODE_PRECONDITION_NOT_MET) {
    note = "domain " + std::to_string(config_.domain) +
           " already exists in this process: write_batch follows that domain's configuration";
  } else {
    return {make_dds_error(d), "cannot create DDS domain " + std::to_string(config_.domain) + ": " +
                                   dds_strretcode(d) + " (check CYCLONEDDS_URI)"};
  }
  return {};
}

// The three topics and their writers; the caller stops on failure.
plugin::Error DdsPublisher::create_writers() {
  struct Spec {
    std::string_view topic;
    const dds_topic_descriptor_t* type;
    Qos qos;
    dds_entity_t* writer;
  };
  const dds_duration_t lease = DDS_MSECS(config_.liveliness_lease_ms);
  Spec specs[] = {
      {kEncoderSampleTopic, &cobridge_EncoderSample_desc,
       encoder_sample_writer_qos(config_.sample_reliability, config_.sample_depth, lease,
                                 config_.samples_on_dispatcher() ? 0 : kMaxBlocking),
       &sample_writer_},
      {kEncoderEventTopic, &cobridge_EncoderEvent_desc, encoder_event_writer_qos(lease), &event_writer_},
      {kDeviceStatusTopic, &cobridge_DeviceStatus_desc, device_status_writer_qos(lease), &status_writer_},
  };
  for (Spec& spec : specs) {
    if (config_.redundancy_node != 0) set_exclusive(spec.qos.get(), kStandbyStrength);
    const std::string name = topic_name(config_.topic_prefix, spec.topic);
    const dds_entity_t topic = dds_create_topic(participant_, spec.type, name.c_str(), nullptr, nullptr);
    if (topic < 0) {
      return {make_dds_error(topic),
              "cannot create topic '" + name + "': " + dds_strretcode(topic) + security_hint(topic)};
    }
    const dds_entity_t writer = dds_create_writer(publisher_, topic, spec.qos.get(), nullptr);
    if (writer < 0) {
      return {make_dds_error(writer),
              "cannot create a writer for '" + name + "': " + dds_strretcode(writer) + security_hint(writer)};
    }
    *spec.writer = writer;
  }
  return {};
}

plugin::Error DdsPublisher::set_ownership_strength(std::int32_t strength) {
  if (config_.redundancy_node == 0) return {};
  const Qos q(dds_create_qos());
  if (!q) return {make_dds_error(DDS_RETCODE_OUT_OF_RESOURCES), "cannot create a QoS: out of memory"};
  dds_qset_ownership_strength(q.get(), strength);
  for (const dds_entity_t w : {sample_writer_, event_writer_, status_writer_}) {
    if (w <= 0) continue;
    if (const dds_return_t rc = dds_set_qos(w, q.get()); rc != DDS_RETCODE_OK)
      return {make_dds_error(rc), std::string("dds_set_qos on a writer: ") + dds_strretcode(rc)};
  }
  return {};
}

plugin::Error DdsPublisher::create_participant(dds_domainid_t domain) {
  // A secured participant joining a domain that another participant of this
  // process made without security crashed Cyclone 0.10.2 (SIGSEGV in its
  // "gc" thread, seen in the unit tests); the other order it refuses. So a
  // secured output wants its domain to itself in this process.
  if (config_.security && dds_lookup_participant(domain, nullptr, 0) > 0) {
    return {make_dds_error(DDS_RETCODE_PRECONDITION_NOT_MET),
            "DDS Security: domain " + std::to_string(config_.domain) +
                " already has a participant in this process (another DDS output?); a secured output needs a domain "
                "of its own here"};
  }
  // DDS Security is a property of the participant: every entity below
  // inherits its identity and permissions (OMG DDS Security 1.1, 8.8.1).
  const Qos qos(config_.security ? dds_create_qos() : nullptr);
  if (config_.security) set_security_properties(qos.get(), *config_.security);
  const dds_entity_t pp = dds_create_participant(domain, qos.get(), nullptr);
  if (pp < 0) {
    return {make_dds_error(pp),
            "cannot create a DDS participant in domain " + std::to_string(config_.domain) + ": " + dds_strretcode(pp) +
                (config_.security ? security_failure_hint(pp, *config_.security) : " (check CYCLONEDDS_URI)")};
  }
  participant_ = pp;
  return {};
}

std::string DdsPublisher::security_hint(dds_return_t rc) const {
  return config_.security ? security_failure_hint(rc, *config_.security) : std::string();
}

void DdsPublisher::stop() noexcept {
  if (participant_ > 0) (void)dds_delete(participant_);  // deletes topics and writers too
  // An explicit domain outlives its participants; it goes with the plugin
  // unless someone else in the process has joined it meanwhile.
  if (domain_ > 0 && dds_get_children(domain_, nullptr, 0) == 0) (void)dds_delete(domain_);
  domain_ = participant_ = publisher_ = sample_writer_ = event_writer_ = status_writer_ = 0;
  unflushed_ = 0;
}

void DdsPublisher::flush() noexcept {
  if (!config_.write_batch || unflushed_ == 0) return;
  if ((unflushed_ & kFlushSample) != 0) dds_write_flush(sample_writer_);
  if ((unflushed_ & kFlushEvent) != 0) dds_write_flush(event_writer_);
  if ((unflushed_ & kFlushStatus) != 0) dds_write_flush(status_writer_);
  unflushed_ = 0;
}

void DdsPublisher::write(dds_entity_t writer, const void* data, std::atomic<std::uint64_t>& counter) noexcept {
  const dds_return_t rc = dds_write(writer, data);
  unflushed_ |= writer == sample_writer_ ? kFlushSample : writer == event_writer_ ? kFlushEvent : kFlushStatus;
  tally(rc, counter);
}

void DdsPublisher::tally(dds_return_t rc, std::atomic<std::uint64_t>& counter) noexcept {
  if (rc == DDS_RETCODE_OK) {
    counter.fetch_add(1, std::memory_order_relaxed);
  } else {
    failures_.fetch_add(1, std::memory_order_relaxed);
    last_failure_.store(rc, std::memory_order_relaxed);
  }
}

void DdsPublisher::write_spilled(const cobridge_sample& s, bool stale, dds_duration_t patience) noexcept {
  if (!started()) return;
  cobridge_EncoderSample m{};
  fill_encoder_sample(m, s, gateway_, slots_.find(s.device_index), stale);
  const dds_time_t give_up = dds_time() + patience;
  dds_return_t rc = dds_write(sample_writer_, &m);
  // Room comes with the reader's acknowledgements; a few short naps rather
  // than a spin (the writer thread has nothing else that cannot wait).
  while (rc == DDS_RETCODE_TIMEOUT && dds_time() < give_up) {
    dds_sleepfor(DDS_USECS(100));
    rc = dds_write(sample_writer_, &m);
  }
  unflushed_ |= kFlushSample;
  tally(rc, samples_);
}

void DdsPublisher::write_status(const DeviceSlot& slot) noexcept {
  cobridge_DeviceStatus st{};
  fill_device_status(st, slot, gateway_);
  write(status_writer_, &st, statuses_);
  recount();
}

void DdsPublisher::recount() noexcept {
  // Status changes are rare (a device appears, goes offline, turns stale):
  // a scan of the table is cheaper than keeping counts right incrementally.
  GatewayCounts c;
  std::uint32_t buses = 0, buses_online = 0;  // bit per bus index (mod 32)
  for (std::uint16_t i = 0; i < slots_.capacity(); ++i) {
    const DeviceSlot* slot = slots_.find(i);
    if (slot == nullptr || !slot->in_use) continue;
    ++c.devices;
    buses |= 1u << (slot->bus_index % 32u);
    if (slot->state.online) {
      ++c.devices_online;
      buses_online |= 1u << (slot->bus_index % 32u);
    }
  }
  c.buses = static_cast<std::uint16_t>(__builtin_popcount(buses));
  c.buses_online = static_cast<std::uint16_t>(__builtin_popcount(buses_online));
  counts_.store(static_cast<std::uint64_t>(c.devices) | static_cast<std::uint64_t>(c.devices_online) << 16 |
                    static_cast<std::uint64_t>(c.buses) << 32 | static_cast<std::uint64_t>(c.buses_online) << 48,
                std::memory_order_relaxed);
}

GatewayCounts DdsPublisher::counts() const noexcept {
  const std::uint64_t v = counts_.load(std::memory_order_relaxed);
  return {static_cast<std::uint16_t>(v), static_cast<std::uint16_t>(v >> 16), static_cast<std::uint16_t>(v >> 32),
          static_cast<std::uint16_t>(v >> 48)};
}

void DdsPublisher::publish(std::span<const cobridge_sample> samples) noexcept {
  write_samples(samples);
  flush();
}

void DdsPublisher::write_samples(std::span<const cobridge_sample> samples) noexcept {
  if (!started()) return;
  for (const cobridge_sample& s : samples) publish_one(s);
}

void DdsPublisher::publish_status(std::span<const cobridge_sample> samples) noexcept {
  if (!started()) return;
  for (const cobridge_sample& s : samples) {
    if (slots_.apply_ahead(s) == StatusChange::kNone) continue;
    if (const DeviceSlot* slot = slots_.find(s.device_index); slot != nullptr) write_status(*slot);
  }
  flush();
}

void DdsPublisher::republish_if_stale(DeviceSlot& slot, const cobridge_sample& status) noexcept {
  if ((status.valid & COBRIDGE_VALID_STATUS) == 0) return;
  const bool became_stale = status.stale != 0 && !slot.samples_stale;
  slot.samples_stale = status.stale != 0;
  if (!became_stale || !slot.has_last_tpdo || config_.samples_on_dispatcher()) return;
  // The last values again, same sequence, flagged.
  cobridge_sample last = slot.last_tpdo;
  last.publish_timestamp_ns = status.publish_timestamp_ns;
  cobridge_EncoderSample m{};
  fill_encoder_sample(m, last, gateway_, &slot, true);
  write(sample_writer_, &m, samples_);
}

void DdsPublisher::publish_one(const cobridge_sample& s) noexcept {
  const GatewayName& gw = gateway_;
  switch (s.kind) {
    case COBRIDGE_SAMPLE_TPDO: {
      const StatusChange change = slots_.apply(s);
      DeviceSlot* slot = slots_.find(s.device_index);
      if (!config_.samples_on_dispatcher()) {
        cobridge_EncoderSample m{};
        fill_encoder_sample(m, s, gw, slot, (s.valid & COBRIDGE_VALID_STATUS) != 0 && s.stale != 0);
        write(sample_writer_, &m, samples_);
      }
      if (slot == nullptr) return;
      slot->samples_stale = false;
      if (change != StatusChange::kNone) write_status(*slot);
      return;
    }
    case COBRIDGE_SAMPLE_EMCY: {
      const DeviceSlot* slot = slots_.find(s.device_index);
      EmcyText text;
      describe_emcy(slot != nullptr ? slot->family.c_str() : "", s, text);
      cobridge_EncoderEvent e{};
      fill_encoder_event(e, s, gw, slot, text);
      write(event_writer_, &e, events_);
      if (slots_.apply(s) != StatusChange::kNone && slot != nullptr) write_status(*slot);
      return;
    }
    case COBRIDGE_SAMPLE_HEARTBEAT:
    case COBRIDGE_SAMPLE_NMT_STATE:
    case COBRIDGE_SAMPLE_STATUS: {
      // kNone as well when the status lane applied it already.
      const StatusChange change = slots_.apply(s);
      DeviceSlot* slot = slots_.find(s.device_index);
      if (slot == nullptr) return;
      if (change != StatusChange::kNone) write_status(*slot);
      // In queue order, after the TPDOs before it, whoever applied it.
      if (s.kind == COBRIDGE_SAMPLE_STATUS) republish_if_stale(*slot, s);
      return;
    }
    default:
      unknown_kind_.fetch_add(1, std::memory_order_relaxed);
      return;
  }
}

void DdsPublisher::forget_instance(const DeviceSlot& slot) noexcept {
  // Status readers see the instance disposed; the sample and event writers
  // release the instance's resources.
  const GatewayName& gw = gateway_;
  cobridge_DeviceStatus st{};
  fill_device_status(st, slot, gw);
  (void)dds_dispose(status_writer_, &st);
  unflushed_ |= kFlushStatus | kFlushSample | kFlushEvent;
  cobridge_sample key{};
  key.bus_index = slot.bus_index;
  key.node_id = slot.node_id;
  cobridge_EncoderSample m{};
  fill_encoder_sample(m, key, gw, &slot, false);
  (void)dds_unregister_instance(sample_writer_, &m);
  cobridge_EncoderEvent e{};
  fill_encoder_event(e, key, gw, &slot, EmcyText{});
  (void)dds_unregister_instance(event_writer_, &e);
}

void DdsPublisher::device(const cobridge_device_info& info) noexcept {
  DeviceSlot* slot = slots_.find(info.device_index);
  if (slot == nullptr) return;
  const bool moved = slot->in_use && (slot->bus_index != info.bus_index || slot->node_id != info.node_id);
  if (started() && slot->in_use && (info.change == COBRIDGE_DEVICE_REMOVED || moved)) forget_instance(*slot);
  if (moved) *slot = DeviceSlot{};  // new key: start from a clean state
  slot = slots_.apply(info);
  if (info.change != COBRIDGE_DEVICE_REMOVED && slot != nullptr) {
    slot->state.updated_ns = realtime_ns();
    if (started()) write_status(*slot);
  }
  recount();
  flush();
}

DdsPublisher::WriterCounts DdsPublisher::writer_counts() const noexcept {
  WriterCounts c;
  for (const dds_entity_t w : {sample_writer_, event_writer_, status_writer_}) {
    if (w <= 0) continue;
    ++c.writers;
    dds_publication_matched_status_t st{};
    if (dds_get_publication_matched_status(w, &st) == DDS_RETCODE_OK) c.matched_readers += st.current_count;
  }
  return c;
}

PublisherStats DdsPublisher::stats() const noexcept {
  PublisherStats s;
  s.samples = samples_.load(std::memory_order_relaxed);
  s.events = events_.load(std::memory_order_relaxed);
  s.statuses = statuses_.load(std::memory_order_relaxed);
  s.write_failures = failures_.load(std::memory_order_relaxed);
  s.last_failure = last_failure_.load(std::memory_order_relaxed);
  s.unknown_kind = unknown_kind_.load(std::memory_order_relaxed);
  return s;
}

}  // namespace cobridge::dds
