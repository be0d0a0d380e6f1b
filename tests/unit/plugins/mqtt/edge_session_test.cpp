// EdgeSession against the Sparkplug 3.0 session rules (spec chapter 5
// "Operational Behavior" and 6.4 "Payloads"), with a fake publisher that
// decodes every message and a fake clock.
#include "edge_session.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <string>
#include <vector>

namespace cobridge::mqtt {
namespace {

struct Message {
  std::string topic;
  PbPayload* p = nullptr;
};

class FakePublisher final : public Publisher {
 public:
  ~FakePublisher() override {
    for (auto& m : sent)
      if (m.p != nullptr) org__eclipse__tahu__protobuf__payload__free_unpacked(m.p, nullptr);
  }
  bool publish(const std::string& topic, std::span<const std::uint8_t> payload) override {
    if (refuse) return false;
    sent.push_back({topic, org__eclipse__tahu__protobuf__payload__unpack(nullptr, payload.size(), payload.data())});
    return true;
  }
  std::vector<std::string> topics(std::size_t from = 0) const {
    std::vector<std::string> out;
    for (std::size_t i = from; i < sent.size(); ++i) out.push_back(sent[i].topic);
    return out;
  }
  std::vector<Message> sent;
  bool refuse = false;
};

const PbMetric* metric(const PbPayload* p, const char* name) {
  for (std::size_t i = 0; i < p->n_metrics; ++i)
    if (p->metrics[i]->name != nullptr && std::string(p->metrics[i]->name) == name) return p->metrics[i];
  return nullptr;
}

DeviceRecord device(std::uint16_t index, const char* name) {
  DeviceRecord r;
  r.device_index = index;
  r.node_id = static_cast<std::uint8_t>(10 + index);
  r.change = COBRIDGE_DEVICE_ADDED;
  r.vendor_id = 0x0000023A;
  r.product_code = 0x4800;
  r.revision = 3;
  r.serial = 1000u + index;
  copy_text(r.name, name);
  copy_text(r.bus_name, "line1");
  copy_text(r.model, "RFC-4800");
  copy_text(r.family, "rotary");
  copy_text(r.position_unit, "deg");
  return r;
}

cobridge_sample tpdo(std::uint16_t index, std::int64_t position, std::uint64_t rx_ns) {
  cobridge_sample s{};
  s.kind = COBRIDGE_SAMPLE_TPDO;
  s.device_index = index;
  s.rx_timestamp_ns = rx_ns;
  s.position = position;
  s.position_eng = static_cast<double>(position) / 10.0;
  s.valid = COBRIDGE_VALID_POSITION | COBRIDGE_VALID_POSITION_ENG;
  return s;
}

cobridge_sample status(std::uint16_t index, bool online) {
  cobridge_sample s{};
  s.kind = COBRIDGE_SAMPLE_STATUS;
  s.device_index = index;
  s.online = online ? 1 : 0;
  s.stale = online ? 0 : 1;
  s.valid = COBRIDGE_VALID_STATUS;
  return s;
}

class EdgeSessionTest : public ::testing::Test {
 protected:
  EdgeSession make(bool wait_for_primary = false) {
    std::array<double, 16> deadband{};
    deadband.fill(0.0);
    deadband_ = deadband;
    return EdgeSession({"plant", "gw1", wait_for_primary}, deadband_, pub);
  }
  FakePublisher pub;
  std::array<double, 16> deadband_{};
};

// Spec 5 / 6.4.18: the first message of a session is NBIRTH, seq 0, with the
// bdSeq of the will and Node Control/Rebirth; then a DBIRTH per device.
TEST_F(EdgeSessionTest, Spec5_NbirthFirstWithBdSeqThenDbirths) {
  EdgeSession s = make();
  s.on_device(device(0, "enc-a"), 100);
  s.on_device(device(1, "enc-b"), 100);
  EXPECT_TRUE(pub.sent.empty());  // no session yet: nothing published
  s.set_link(true, 7, 200);
  ASSERT_EQ(pub.topics(), (std::vector<std::string>{"spBv1.0/plant/NBIRTH/gw1", "spBv1.0/plant/DBIRTH/gw1/enc-a",
                                                    "spBv1.0/plant/DBIRTH/gw1/enc-b"}));
  const PbPayload* nbirth = pub.sent[0].p;
  ASSERT_NE(nbirth, nullptr);
  EXPECT_TRUE(nbirth->has_seq);
  EXPECT_EQ(nbirth->seq, 0u);
  const PbMetric* bd = metric(nbirth, "bdSeq");
  ASSERT_NE(bd, nullptr);
  EXPECT_EQ(bd->long_value, 7u);
  const PbMetric* rebirth = metric(nbirth, "Node Control/Rebirth");
  ASSERT_NE(rebirth, nullptr);
  EXPECT_EQ(rebirth->datatype, 11u);
  EXPECT_FALSE(rebirth->boolean_value);
  EXPECT_EQ(pub.sent[1].p->seq, 1u);
  EXPECT_EQ(pub.sent[2].p->seq, 2u);
}

// Spec 6.4.x DBIRTH: every metric DDATA may carry, with name, alias,
// datatype; unknown values null; engineering unit and identity 0x1018.
TEST_F(EdgeSessionTest, Spec6_DbirthHasEveryMetricAliasDatatypeAndIdentity) {
  EdgeSession s = make();
  s.on_device(device(2, "enc"), 100);
  s.set_link(true, 0, 200);
  s.on_sample(tpdo(2, 1234, 150'000'000), 300);  // born already; this is DDATA
  s.set_link(true, 1, 400);                      // new session: DBIRTH holds the last value
  const PbPayload* db = pub.sent.back().p;
  ASSERT_EQ(pub.sent.back().topic, "spBv1.0/plant/DBIRTH/gw1/enc");
  EXPECT_EQ(db->n_metrics, process_metrics().size() + command_metrics().size() + identity_metrics().size());
  for (const MetricDef& m : process_metrics()) {
    const PbMetric* pm = metric(db, m.name);
    ASSERT_NE(pm, nullptr) << m.name;
    EXPECT_EQ(pm->alias, device_alias(2, m.id)) << m.name;
    EXPECT_EQ(pm->datatype, static_cast<std::uint32_t>(m.type)) << m.name;
  }
  EXPECT_EQ(static_cast<std::int64_t>(metric(db, "Position")->long_value), 1234);
  EXPECT_EQ(metric(db, "Position")->timestamp, 150u);  // the frame's receive time in ms
  EXPECT_TRUE(metric(db, "Speed")->is_null);            // never heard
  const PbMetric* eng = metric(db, "Position/Engineering");
  ASSERT_NE(eng->properties, nullptr);
  EXPECT_STREQ(eng->properties->keys[0], "engUnit");
  EXPECT_STREQ(eng->properties->values[0]->string_value, "deg");
  EXPECT_EQ(metric(db, "Properties/Vendor ID")->int_value, 0x23Au);
  EXPECT_EQ(metric(db, "Properties/Serial Number")->int_value, 1002u);
  EXPECT_STREQ(metric(db, "Properties/Model")->string_value, "RFC-4800");
}

// Spec 6.4.x DCMD: a host writes only metrics the DBIRTH declared, so the
// commands are in it (writable ones false / null) with their aliases.
TEST_F(EdgeSessionTest, Spec6_DbirthDeclaresTheCommandMetrics) {
  EdgeSession s = make();
  s.on_device(device(1, "enc"), 100);
  s.set_link(true, 0, 200);
  const PbPayload* db = pub.sent.back().p;
  for (const MetricDef& m : command_metrics()) {
    const PbMetric* pm = metric(db, m.name);
    ASSERT_NE(pm, nullptr) << m.name;
    EXPECT_EQ(pm->alias, device_alias(1, m.id)) << m.name;
    EXPECT_EQ(pm->datatype, static_cast<std::uint32_t>(m.type)) << m.name;
  }
  EXPECT_FALSE(metric(db, "Command/Store")->boolean_value);
  EXPECT_TRUE(metric(db, "Command/Result")->is_null);
}

// A command's outcome comes back as the device's DDATA (by alias), in seq.
TEST_F(EdgeSessionTest, Spec6_CommandResultAsDdata) {
  EdgeSession s = make();
  s.on_device(device(0, "enc"), 100);
  s.set_link(true, 0, 200);
  EXPECT_EQ(s.device_index_of("enc"), 0);
  EXPECT_EQ(s.device_index_of("nope"), -1);
  s.publish_result(CommandResult{0, "scada-1", "refused: writes are disabled", 16}, 300);
  const Message& m = pub.sent.back();
  EXPECT_EQ(m.topic, "spBv1.0/plant/DDATA/gw1/enc");
  EXPECT_EQ(m.p->seq, 2u);
  ASSERT_EQ(m.p->n_metrics, 3u);
  EXPECT_EQ(m.p->metrics[0]->alias, device_alias(0, DeviceMetric::kCmdClient));
  EXPECT_STREQ(m.p->metrics[0]->string_value, "scada-1");
  EXPECT_STREQ(m.p->metrics[1]->string_value, "refused: writes are disabled");
  EXPECT_EQ(m.p->metrics[2]->int_value, 16u);
  s.set_link(false, 1, 400);
  s.publish_result(CommandResult{0, "c", "done", 0}, 500);  // no session: counted, not sent
  EXPECT_EQ(pub.sent.size(), 3u);
}

// Spec 6.4.4: aliases unique across the edge node (tck-id-payloads-alias-uniqueness).
TEST(SparkplugMetrics, Spec644_AliasesUniqueAcrossTheEdgeNode) {
  std::set<std::uint64_t> seen = {kRebirthAlias};
  for (std::uint16_t dev = 0; dev < 300; ++dev) {
    for (const MetricDef& m : process_metrics()) EXPECT_TRUE(seen.insert(device_alias(dev, m.id)).second);
    for (const MetricDef& m : command_metrics()) EXPECT_TRUE(seen.insert(device_alias(dev, m.id)).second);
    for (const MetricDef& m : identity_metrics()) EXPECT_TRUE(seen.insert(device_alias(dev, m.id)).second);
  }
}

// DDATA: by alias only, each metric stamped with the frame's receive time.
TEST_F(EdgeSessionTest, Spec6_DdataByAliasWithReceiveTime) {
  EdgeSession s = make();
  s.on_device(device(0, "enc"), 100);
  s.set_link(true, 0, 200);
  const std::size_t before = pub.sent.size();
  s.on_sample(tpdo(0, 42, 1'700'000'000'123'456'789ull), 300);
  ASSERT_EQ(pub.sent.size(), before + 1);
  const Message& m = pub.sent.back();
  EXPECT_EQ(m.topic, "spBv1.0/plant/DDATA/gw1/enc");
  ASSERT_EQ(m.p->n_metrics, 2u);
  EXPECT_EQ(m.p->metrics[0]->name, nullptr);
  EXPECT_EQ(m.p->metrics[0]->alias, device_alias(0, DeviceMetric::kPosition));
  EXPECT_EQ(m.p->metrics[0]->long_value, 42u);
  EXPECT_EQ(m.p->metrics[0]->timestamp, 1'700'000'000'123ull);
  EXPECT_DOUBLE_EQ(m.p->metrics[1]->double_value, 4.2);
}

// Spec 6.4.3: seq 0..255 over every message but NDEATH, wrapping to 0.
TEST_F(EdgeSessionTest, Spec643_SeqWrapsAt256AndRestartsWithNbirth) {
  EdgeSession s = make();
  s.on_device(device(0, "enc"), 100);
  s.set_link(true, 0, 200);
  for (int i = 1; i <= 600; ++i) s.on_sample(tpdo(0, i, std::uint64_t{1'000'000} * static_cast<std::uint64_t>(i)), 300);
  std::uint64_t expect = 0;
  for (const Message& m : pub.sent) {
    ASSERT_TRUE(m.p->has_seq);
    EXPECT_EQ(m.p->seq, expect);
    expect = (expect + 1) % 256;
  }
  s.rebirth(400);
  const auto nb = std::find_if(pub.sent.begin() + 602, pub.sent.end(),
                               [](const Message& m) { return m.topic.find("NBIRTH") != std::string::npos; });
  ASSERT_NE(nb, pub.sent.end());
  EXPECT_EQ(nb->p->seq, 0u);
}

// [outputs.mqtt.metrics]: a device's DBIRTH declares only its metric set (commands and
// identity always), and its DDATA carry only those.
TEST_F(EdgeSessionTest, Spec6_MetricSetPerDeviceInDbirthAndDdata) {
  EdgeSession::Ids ids{"plant", "gw1", false};
  ids.metrics.sets = {{"enc-a", 1u << process_index(DeviceMetric::kPositionEng)}};
  EdgeSession s(ids, deadband_, pub);
  s.on_device(device(0, "enc-a"), 100);
  s.on_device(device(1, "enc-b"), 100);
  s.set_link(true, 0, 200);
  const PbPayload* a = pub.sent[1].p;
  ASSERT_EQ(pub.sent[1].topic, "spBv1.0/plant/DBIRTH/gw1/enc-a");
  EXPECT_EQ(a->n_metrics, 1 + command_metrics().size() + identity_metrics().size());
  EXPECT_NE(metric(a, "Position/Engineering"), nullptr);
  EXPECT_EQ(metric(a, "Position"), nullptr);
  EXPECT_NE(metric(a, "Properties/Serial Number"), nullptr);
  EXPECT_EQ(pub.sent[2].p->n_metrics, process_metrics().size() + command_metrics().size() + identity_metrics().size());
  s.on_sample(tpdo(0, 42, 1'000'000), 300);
  ASSERT_EQ(pub.sent.back().topic, "spBv1.0/plant/DDATA/gw1/enc-a");
  ASSERT_EQ(pub.sent.back().p->n_metrics, 1u);
  EXPECT_EQ(pub.sent.back().p->metrics[0]->alias, device_alias(0, DeviceMetric::kPositionEng));
  s.on_sample(tpdo(1, 42, 1'000'000), 300);
  EXPECT_EQ(pub.sent.back().p->n_metrics, 2u);  // enc-b: Position and Position/Engineering
}

// Report by exception: unchanged values are not sent; a deadband holds
// back changes smaller than it.
TEST_F(EdgeSessionTest, ReportByExceptionAndDeadband) {
  std::array<double, 16> db{};
  db[process_index(DeviceMetric::kPosition)] = 10.0;
  db[process_index(DeviceMetric::kPositionEng)] = 1.0;
  EdgeSession s({"plant", "gw1", false}, db, pub);
  s.on_device(device(0, "enc"), 100);
  s.set_link(true, 0, 200);
  s.on_sample(tpdo(0, 100, 1'000'000), 300);  // first value: sent
  const std::size_t n = pub.sent.size();
  s.on_sample(tpdo(0, 100, 2'000'000), 300);  // unchanged
  s.on_sample(tpdo(0, 105, 3'000'000), 300);  // within the deadband
  EXPECT_EQ(pub.sent.size(), n);
  s.on_sample(tpdo(0, 111, 4'000'000), 300);  // 11 from the last sent
  ASSERT_EQ(pub.sent.size(), n + 1);
  EXPECT_EQ(pub.sent.back().p->metrics[0]->long_value, 111u);
}

// DDEATH when supervision takes the device offline, DBIRTH when it is back.
TEST_F(EdgeSessionTest, Spec5_DdeathOnOfflineDbirthOnReturn) {
  EdgeSession s = make();
  s.on_device(device(0, "enc"), 100);
  s.set_link(true, 0, 200);
  const std::size_t n = pub.sent.size();
  s.on_sample(status(0, false), 300);
  ASSERT_EQ(pub.topics(n), (std::vector<std::string>{"spBv1.0/plant/DDEATH/gw1/enc"}));
  EXPECT_EQ(pub.sent.back().p->n_metrics, 0u);
  EXPECT_TRUE(pub.sent.back().p->has_seq);
  s.on_sample(tpdo(0, 5, 1'000'000), 310);  // a late frame: no DDATA for a dead device
  EXPECT_EQ(pub.sent.size(), n + 1);
  s.on_sample(status(0, true), 400);
  ASSERT_EQ(pub.topics(n + 1), (std::vector<std::string>{"spBv1.0/plant/DBIRTH/gw1/enc"}));
  EXPECT_EQ(s.counters().deaths.load(), 1u);
}

// Spec 5 (primary host): nothing before STATE online; births when it is.
TEST_F(EdgeSessionTest, Spec5_PrimaryHostHoldsBirthsUntilOnline) {
  EdgeSession s = make(true);
  s.on_device(device(0, "enc"), 100);
  s.set_link(true, 3, 200);
  s.on_sample(tpdo(0, 1, 1'000'000), 250);
  EXPECT_TRUE(pub.sent.empty());
  s.set_primary_online(true, 300);
  ASSERT_EQ(pub.topics(), (std::vector<std::string>{"spBv1.0/plant/NBIRTH/gw1", "spBv1.0/plant/DBIRTH/gw1/enc"}));
  s.set_primary_online(false, 400);
  s.on_sample(tpdo(0, 2, 2'000'000), 450);
  EXPECT_EQ(pub.sent.size(), 2u);  // held while the host is offline
  s.set_primary_online(true, 500);
  EXPECT_EQ(pub.topics(2), (std::vector<std::string>{"spBv1.0/plant/NBIRTH/gw1", "spBv1.0/plant/DBIRTH/gw1/enc"}));
}

// A new MQTT session: NBIRTH again with the new bdSeq.
TEST_F(EdgeSessionTest, Spec5_ReconnectBirthsWithNewBdSeq) {
  EdgeSession s = make();
  s.set_link(true, 0, 100);
  s.set_link(false, 1, 200);
  s.on_sample(tpdo(0, 1, 1), 250);
  EXPECT_EQ(pub.sent.size(), 1u);
  s.set_link(true, 1, 300);
  ASSERT_EQ(pub.sent.size(), 2u);
  EXPECT_EQ(metric(pub.sent[1].p, "bdSeq")->long_value, 1u);
}

// Store and forward (spec 5, tck-id-operational-behavior-data-*): DDATA taken
// while the broker is away comes after the new NBIRTH and DBIRTH, with
// is_historical, oldest first, each stamped with its frame's time, in seq.
TEST_F(EdgeSessionTest, Spec5_StoreAndForwardAfterTheBirthsHistoricalInOrder) {
  EdgeSession s({"plant", "gw1", false, 100, 100'000}, deadband_, pub);
  s.on_device(device(0, "enc"), 100);
  s.set_link(true, 0, 200);
  s.on_sample(tpdo(0, 1, 1'000'000'000), 300);  // live DDATA
  s.set_link(false, 1, 400);
  for (int i = 2; i <= 80; ++i)  // 79 positions while away
    s.on_sample(tpdo(0, i, static_cast<std::uint64_t>(i) * 1'000'000'000), 500);
  s.on_sample(tpdo(0, 80, 81'000'000'000), 500);  // unchanged: not stored (report by exception)
  EXPECT_EQ(s.counters().stored.load(), 79u);
  const std::size_t n = pub.sent.size();
  s.set_link(true, 1, 90'000);
  ASSERT_GE(pub.sent.size(), n + 4);
  EXPECT_EQ(pub.sent[n].topic, "spBv1.0/plant/NBIRTH/gw1");
  EXPECT_EQ(pub.sent[n + 1].topic, "spBv1.0/plant/DBIRTH/gw1/enc");
  std::vector<std::pair<std::uint64_t, std::uint64_t>> history;  // (timestamp, position)
  std::uint64_t seq = pub.sent[n + 1].p->seq;
  for (std::size_t i = n + 2; i < pub.sent.size(); ++i) {
    const Message& m = pub.sent[i];
    ASSERT_EQ(m.topic, "spBv1.0/plant/DDATA/gw1/enc");
    EXPECT_EQ(m.p->seq, ++seq);
    for (std::size_t j = 0; j < m.p->n_metrics; ++j) {
      const PbMetric* pm = m.p->metrics[j];
      EXPECT_TRUE(pm->has_is_historical && pm->is_historical);
      if (pm->alias == device_alias(0, DeviceMetric::kPosition)) history.emplace_back(pm->timestamp, pm->long_value);
    }
  }
  ASSERT_EQ(history.size(), 79u);
  for (std::size_t i = 0; i < history.size(); ++i) {
    EXPECT_EQ(history[i].second, i + 2);
    EXPECT_EQ(history[i].first, (i + 2) * 1000);  // the frame's receive time in ms
  }
  EXPECT_EQ(s.counters().replayed.load(), 79u);
  s.on_sample(tpdo(0, 99, 91'000'000'000), 91'000);  // live again: not historical
  EXPECT_FALSE(pub.sent.back().p->metrics[0]->has_is_historical);
}

// Batching (batch_samples): the DDATA of one pass over the queue go out as
// one message per device at flush(), every metric with its own frame's time
// (spec 6.4.x: a metric's timestamp is its own), no is_historical, one seq.
TEST_F(EdgeSessionTest, Spec6_4_BatchedDdataOneMessagePerDeviceEachMetricWithItsFramesTime) {
  EdgeSession s({"plant", "gw1", false, 0, 0, 32}, deadband_, pub);
  s.on_device(device(0, "a"), 100);
  s.on_device(device(1, "b"), 100);
  s.set_link(true, 0, 200);
  const std::size_t n = pub.sent.size();
  for (int i = 1; i <= 5; ++i) {
    s.on_sample(tpdo(0, i, static_cast<std::uint64_t>(i) * 1'000'000), 300);
    s.on_sample(tpdo(1, 100 + i, static_cast<std::uint64_t>(i) * 1'000'000 + 500'000), 300);
  }
  EXPECT_EQ(pub.sent.size(), n) << "nothing before flush()";
  s.flush();
  ASSERT_EQ(pub.topics(n), (std::vector<std::string>{"spBv1.0/plant/DDATA/gw1/a", "spBv1.0/plant/DDATA/gw1/b"}));
  const PbPayload* a = pub.sent[n].p;
  EXPECT_EQ(a->seq, pub.sent[n - 1].p->seq + 1);
  EXPECT_EQ(pub.sent[n + 1].p->seq, a->seq + 1);
  std::vector<std::pair<std::uint64_t, std::int64_t>> got;
  for (std::size_t j = 0; j < a->n_metrics; ++j) {
    EXPECT_FALSE(a->metrics[j]->has_is_historical);
    if (a->metrics[j]->alias == device_alias(0, DeviceMetric::kPosition))
      got.emplace_back(a->metrics[j]->timestamp, static_cast<std::int64_t>(a->metrics[j]->long_value));
  }
  EXPECT_EQ(got, (std::vector<std::pair<std::uint64_t, std::int64_t>>{{1, 1}, {2, 2}, {3, 3}, {4, 4}, {5, 5}}));
  s.flush();
  EXPECT_EQ(pub.sent.size(), n + 2) << "a second flush has nothing to send";
}

// A device's batched DDATA precede its DDEATH (spec 5: DDATA of a dead
// device would be out of order), and a full batch is sent before it grows.
TEST_F(EdgeSessionTest, Spec5_BatchGoesOutBeforeTheDeathAndWhenFull) {
  EdgeSession s({"plant", "gw1", false, 0, 0, 2}, deadband_, pub);
  s.on_device(device(0, "a"), 100);
  s.set_link(true, 0, 200);
  const std::size_t n = pub.sent.size();
  s.on_sample(tpdo(0, 1, 1'000'000), 300);
  s.on_sample(tpdo(0, 2, 2'000'000), 300);
  EXPECT_EQ(pub.sent.size(), n);
  s.on_sample(tpdo(0, 3, 3'000'000), 300);  // the batch of 2 is full: it goes first
  ASSERT_EQ(pub.sent.size(), n + 1);
  EXPECT_EQ(pub.sent[n].p->n_metrics, 4u);  // 2 samples x (Position, position in units)
  s.on_sample(status(0, false), 400);
  EXPECT_EQ(pub.topics(n), (std::vector<std::string>{"spBv1.0/plant/DDATA/gw1/a", "spBv1.0/plant/DDATA/gw1/a",
                                                     "spBv1.0/plant/DDEATH/gw1/a"}));
  s.flush();
  EXPECT_EQ(pub.sent.size(), n + 3);
}

// A full store drops its oldest entries and counts them.
TEST_F(EdgeSessionTest, StoreFullDropsOldestCounted) {
  EdgeSession s({"plant", "gw1", false, 10, 0}, deadband_, pub);
  s.on_device(device(0, "enc"), 100);
  for (int i = 1; i <= 25; ++i) s.on_sample(tpdo(0, i, static_cast<std::uint64_t>(i) * 1'000'000), 200);
  EXPECT_EQ(s.counters().store_drops.load(), 15u);
  s.set_link(true, 0, 300);
  const PbMetric* first = nullptr;
  for (const Message& m : pub.sent)
    if (m.topic.find("DDATA") != std::string::npos && first == nullptr) first = m.p->metrics[0];
  ASSERT_NE(first, nullptr);
  EXPECT_EQ(first->long_value, 16u);  // 1..15 dropped, oldest first
}

TEST_F(EdgeSessionTest, DropsCountedWhenTheClientRefuses) {
  EdgeSession s = make();
  pub.refuse = true;
  s.set_link(true, 0, 100);
  EXPECT_EQ(s.counters().drops.load(), 1u);
  EXPECT_EQ(s.counters().messages.load(), 0u);
}

// Spec 6.4.19: NDEATH carries bdSeq and no seq.
TEST(SparkplugNdeath, Spec6419_BdSeqOnlyNoSeq) {
  PayloadBuilder b;
  std::array<std::uint8_t, 128> buf{};
  const std::size_t n = encode_ndeath(b, 9, 1000, buf);
  ASSERT_GT(n, 0u);
  PbPayload* p = org__eclipse__tahu__protobuf__payload__unpack(nullptr, n, buf.data());
  ASSERT_NE(p, nullptr);
  EXPECT_FALSE(p->has_seq);
  ASSERT_EQ(p->n_metrics, 1u);
  EXPECT_STREQ(p->metrics[0]->name, "bdSeq");
  EXPECT_EQ(p->metrics[0]->datatype, 4u);  // Int64
  EXPECT_EQ(p->metrics[0]->long_value, 9u);
  org__eclipse__tahu__protobuf__payload__free_unpacked(p, nullptr);
}

}  // namespace
}  // namespace cobridge::mqtt
