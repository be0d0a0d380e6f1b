// The DDS output plugin end to end on real Cyclone DDS: libcobridge_dds.so is
// loaded through pipeline::PluginHost (real dlopen), fed samples and device
// announcements, and read back by DDS readers of the generated IDL types in
// this process, and by `cobridge watch` in another process over loopback.
//
// Each test process uses its own DDS domain and gateway id (from its pid),
// and Cyclone is pinned to the loopback interface, so parallel runs and other
// DDS traffic on the host do not interfere.
#include "pipeline/plugin_host.hpp"
#include "pipeline/sample.hpp"

#include "canopen/emcy.hpp"
#include "cobridge_idl/cobridge.h"
#include "dds/sample_mapping.hpp"
#include "unit/plugins/dds/test_ca.hpp"
#include "unit/support/eventually.hpp"

#include <dds/dds.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstddef>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <span>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace fs = std::filesystem;
using namespace cobridge;
using namespace std::chrono_literals;
using cobridge::test::eventually;

namespace {

// Before any participant exists: loopback only, with multicast forced on
// (lo has no MULTICAST flag, but Linux delivers loopback multicast).
const bool kLoopback = [] {
  ::setenv("CYCLONEDDS_URI", "<General><Interfaces><NetworkInterface name=\"lo\" multicast=\"true\"/></Interfaces></General>",
           1);
  return true;
}();

const fs::path kPlugin = COBRIDGE_DDS_PLUGIN_FILE;
const fs::path kCli = COBRIDGE_CLI_FILE;

std::uint32_t test_domain() { return 20u + static_cast<std::uint32_t>(::getpid()) % 200u; }
std::string test_gateway() { return "gw-test-" + std::to_string(::getpid()); }

class LogCapture {
 public:
  pipeline::PluginHost::LogSink sink() {
    return [this](pipeline::LogLevel, std::string_view instance, std::string_view msg) {
      std::lock_guard lock(mutex_);
      lines_.push_back(std::string(instance) + ": " + std::string(msg));
    };
  }
  std::string all() {
    std::lock_guard lock(mutex_);
    std::string s;
    for (const auto& l : lines_) s += l + "\n";
    return s;
  }

 private:
  std::mutex mutex_;
  std::vector<std::string> lines_;
};

// A started DDS plugin instance.
struct Plugin {
  LogCapture log;
  pipeline::PluginHost host;
  explicit Plugin(const std::string& config, std::uint8_t redundancy_node = 0)
      : host({kPlugin.parent_path(), test_gateway(), log.sink(), {}, redundancy_node}) {
    const Error err = host.load({"dds", "dds", kPlugin, config});
    EXPECT_FALSE(err) << err.to_string();
    const auto failed = host.start_all();
    EXPECT_TRUE(failed.empty()) << log.all();
    EXPECT_EQ(host.started_count(), 1u) << log.all();
  }
};

std::string base_config(const std::string& extra = "") {
  return "domain = " + std::to_string(test_domain()) + "\n" + extra;
}

cobridge_device_info device(std::uint16_t index, std::uint8_t bus, std::uint8_t node, const char* name,
                            const char* family = "novotechnik-rotary",
                            std::uint8_t change = COBRIDGE_DEVICE_ADDED) {
  cobridge_device_info d{};
  d.struct_size = sizeof d;
  d.device_index = index;
  d.bus_index = bus;
  d.node_id = node;
  d.change = change;
  d.vendor_id = 0x0000065;
  d.product_code = 0x4711;
  d.revision = 0x00010002;
  d.serial = 123456u + index;
  d.name = name;
  d.bus_name = bus == 0 ? "can0" : "can1";
  d.model = "RSC-2800";
  d.family = family;
  d.position_unit = "deg";
  return d;
}

cobridge_sample header(std::uint16_t index, std::uint8_t bus, std::uint8_t node, std::uint8_t kind,
                       std::uint32_t seq) {
  cobridge_sample s{};
  s.rx_timestamp_ns = 1'700'000'000'000'000'000ull + seq * 1000ull;
  s.publish_timestamp_ns = s.rx_timestamp_ns + 500;
  s.sequence = seq;
  s.device_index = index;
  s.bus_index = bus;
  s.node_id = node;
  s.kind = kind;
  return s;
}

cobridge_sample tpdo(std::uint16_t index, std::uint8_t bus, std::uint8_t node, std::uint32_t seq) {
  cobridge_sample s = header(index, bus, node, COBRIDGE_SAMPLE_TPDO, seq);
  s.cob_id = static_cast<std::uint16_t>(0x180 + node);
  s.sync_counter = static_cast<std::uint8_t>(1 + seq % 240);
  s.position = 1000 * static_cast<std::int64_t>(seq) - 7;
  s.position_eng = static_cast<double>(s.position) * 0.087890625;
  s.speed = -static_cast<std::int32_t>(seq);
  s.cam_state = static_cast<std::uint8_t>(seq & 0x0F);
  s.work_area_state = static_cast<std::uint8_t>(seq & 0x03);
  s.alarms = static_cast<std::uint16_t>(seq & 0x1);
  s.warnings = static_cast<std::uint16_t>(seq & 0x2);
  s.temperature_dC = 253;
  s.voltage_dV = 240;
  s.valid = COBRIDGE_VALID_POSITION | COBRIDGE_VALID_POSITION_ENG | COBRIDGE_VALID_SPEED | COBRIDGE_VALID_CAM_STATE |
            COBRIDGE_VALID_WORK_AREA_STATE | COBRIDGE_VALID_ALARMS | COBRIDGE_VALID_WARNINGS |
            COBRIDGE_VALID_TEMPERATURE | COBRIDGE_VALID_VOLTAGE | COBRIDGE_VALID_RAW;
  return s;
}

// A reader in its own participant.
class Reader {
 public:
  // Every take on a reader uses this many slots (see the disposal test).
  static constexpr std::size_t kMax = 256;
  Reader(const dds_topic_descriptor_t* type, const std::string& topic, dds_reliability_kind_t rel,
         dds_durability_kind_t dur, bool keep_all, std::int32_t depth = 1,
         dds_ownership_kind_t ownership = DDS_OWNERSHIP_SHARED) {
    participant_ = dds_create_participant(static_cast<dds_domainid_t>(test_domain()), nullptr, nullptr);
    EXPECT_GT(participant_, 0) << dds_strretcode(participant_);
    const dds_entity_t t = dds_create_topic(participant_, type, topic.c_str(), nullptr, nullptr);
    EXPECT_GT(t, 0) << dds_strretcode(t);
    dds_qos_t* q = dds_create_qos();
    dds_qset_reliability(q, rel, DDS_SECS(1));
    dds_qset_durability(q, dur);
    dds_qset_history(q, keep_all ? DDS_HISTORY_KEEP_ALL : DDS_HISTORY_KEEP_LAST, depth);
    dds_qset_ownership(q, ownership);
    reader_ = dds_create_reader(participant_, t, q, nullptr);
    dds_delete_qos(q);
    EXPECT_GT(reader_, 0) << dds_strretcode(reader_);
  }
  ~Reader() {
    if (participant_ > 0) dds_delete(participant_);
  }
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  // Takes until `want` samples of this test's gateway arrived or 10 s passed;
  // `copy` receives each loaned sample (valid data only).
  template <typename T>
  void take(std::size_t want, const std::function<void(const T&)>& copy, std::chrono::milliseconds limit = 10s) {
    const auto deadline = std::chrono::steady_clock::now() + limit;
    const std::string gw = test_gateway();
    std::size_t got = 0;
    while (got < want && std::chrono::steady_clock::now() < deadline) {
      void* buf[kMax] = {};
      dds_sample_info_t info[kMax];
      const int n = dds_take(reader_, buf, info, kMax, kMax);
      if (n <= 0) {
        std::this_thread::sleep_for(2ms);
        continue;
      }
      for (int i = 0; i < n; ++i) {
        const auto idx = static_cast<std::size_t>(i);
        if (!info[idx].valid_data) continue;
        const T& v = *static_cast<const T*>(buf[idx]);
        if (gw != v.gateway_id) continue;
        copy(v);
        ++got;
      }
      dds_return_loan(reader_, buf, n);
    }
  }
  dds_entity_t id() const { return reader_; }

 private:
  dds_entity_t participant_ = 0;
  dds_entity_t reader_ = 0;
};

struct GotSample {
  std::string gateway_id, device_name;
  cobridge_EncoderSample v;
};
GotSample copy_sample(const cobridge_EncoderSample& s) {
  GotSample g{s.gateway_id, s.device_name, s};
  g.v.gateway_id = g.v.device_name = nullptr;
  return g;
}

struct GotStatus {
  std::string gateway_id, name, bus_name, model, family, unit;
  cobridge_DeviceStatus v;
};
GotStatus copy_status(const cobridge_DeviceStatus& s) {
  GotStatus g{s.gateway_id, s.name, s.bus_name, s.model, s.family, s.position_unit, s};
  g.v.gateway_id = g.v.name = g.v.bus_name = g.v.model = g.v.family = g.v.position_unit = nullptr;
  return g;
}

struct GotEvent {
  std::string gateway_id, device_name, text, source;
  cobridge_EncoderEvent v;
};
GotEvent copy_event(const cobridge_EncoderEvent& e) {
  GotEvent g{e.gateway_id, e.device_name, e.text, e.source, e};
  g.v.gateway_id = g.v.device_name = g.v.text = g.v.source = nullptr;
  return g;
}

void expect_values(const GotSample& g, const cobridge_sample& s, const char* name) {
  EXPECT_EQ(g.gateway_id, test_gateway());
  EXPECT_EQ(g.v.gateway_key, dds::gateway_key(test_gateway()));
  EXPECT_EQ(g.device_name, name);
  EXPECT_EQ(g.v.bus, s.bus_index);
  EXPECT_EQ(g.v.node_id, s.node_id);
  EXPECT_EQ(g.v.position, s.position);
  EXPECT_EQ(g.v.position_eng, s.position_eng);
  EXPECT_EQ(g.v.speed, s.speed);
  EXPECT_EQ(g.v.cam_state, s.cam_state);
  EXPECT_EQ(g.v.work_area_state, s.work_area_state);
  EXPECT_EQ(g.v.alarms, s.alarms);
  EXPECT_EQ(g.v.warnings, s.warnings);
  EXPECT_EQ(g.v.temperature_dC, s.temperature_dC);
  EXPECT_EQ(g.v.voltage_dV, s.voltage_dV);
  // The RAW bit is not a process value: the topic carries the IDL's bits only.
  EXPECT_EQ(g.v.valid, s.valid & 0x01FFu);
  EXPECT_EQ(g.v.rx_timestamp_ns, s.rx_timestamp_ns);
  EXPECT_EQ(g.v.publish_timestamp_ns, s.publish_timestamp_ns);
  EXPECT_EQ(g.v.sequence_number, s.sequence);
  EXPECT_EQ(g.v.sync_counter, s.sync_counter);
  EXPECT_FALSE(g.v.stale);
}

// CiA 301 §7.2.2 (PDO): every decoded TPDO of two devices on two buses
// reaches a reliable EncoderSample reader with the same values, in order per
// device, keyed by gateway id, bus and node-ID.
// Feeds 1500 TPDOs to each of two devices in batches of 64 and checks that
// `reader` gets all of them, in order per device, with their values.
void expect_all_in_order(Plugin& p, Reader& reader) {
  p.host.announce(device(0, 0, 5, "axis 1"));
  p.host.announce(device(1, 1, 7, "axis 2"));

  constexpr std::uint32_t kPerDevice = 1500;
  std::vector<cobridge_sample> sent;
  std::vector<cobridge_sample> batch;
  for (std::uint32_t seq = 1; seq <= kPerDevice; ++seq) {
    batch.push_back(tpdo(0, 0, 5, seq));
    batch.push_back(tpdo(1, 1, 7, seq));
    if (batch.size() == 64 || seq == kPerDevice) {
      p.host.deliver(batch);
      sent.insert(sent.end(), batch.begin(), batch.end());
      batch.clear();
    }
  }
  std::vector<GotSample> got;
  reader.take<cobridge_EncoderSample>(sent.size(), [&](const cobridge_EncoderSample& s) { got.push_back(copy_sample(s)); });
  ASSERT_EQ(got.size(), sent.size());

  // Order is per instance (device); split both sides by node.
  std::map<int, std::vector<const GotSample*>> by_node;
  for (const auto& g : got) by_node[g.v.node_id].push_back(&g);
  std::map<int, std::vector<const cobridge_sample*>> sent_by_node;
  for (const auto& s : sent) sent_by_node[s.node_id].push_back(&s);
  ASSERT_EQ(by_node.size(), 2u);
  for (const auto& [node, list] : sent_by_node) {
    ASSERT_EQ(by_node[node].size(), list.size());
    for (std::size_t i = 0; i < list.size(); ++i) {
      expect_values(*by_node[node][i], *list[i], node == 5 ? "axis 1" : "axis 2");
      if (::testing::Test::HasFailure()) return;
    }
  }
}

TEST(DdsPlugin, Cia301_7_2_2_ReliableSamplesArriveInOrderWithValuesAndKeys) {
  // The reader's participant creates the domain first, so the plugin joins
  // it as it is and says that write_batch follows that domain.
  Reader reader(&cobridge_EncoderSample_desc, "EncoderSample", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_VOLATILE, true);
  Plugin p(base_config("sample_reliability = \"reliable\"\n"));
  EXPECT_NE(p.log.all().find("write_batch follows that domain's configuration"), std::string::npos) << p.log.all();
  expect_all_in_order(p, reader);
}

// docs/dds.md "Configuration", write_batch: the plugin creates the domain
// with Cyclone's WriteBatch and flushes after every drained batch; with it
// on (the default) and off, every sample arrives, in order, with its values.
TEST(DdsPlugin, DocsDds_WriteBatchOnAndOffDeliverEverySampleInOrder) {
  for (const char* batching : {"true", "false"}) {
    SCOPED_TRACE(std::string("write_batch = ") + batching);
    Plugin p(base_config("sample_reliability = \"reliable\"\nwrite_batch = " + std::string(batching) + "\n"));
    EXPECT_EQ(p.log.all().find("already exists"), std::string::npos) << p.log.all();
    EXPECT_EQ(p.log.all().find("write batching") != std::string::npos, std::string(batching) == "true") << p.log.all();
    Reader reader(&cobridge_EncoderSample_desc, "EncoderSample", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_VOLATILE, true);
    // Local endpoints match when the reader is created; check, not assume.
    dds_subscription_matched_status_t st{};
    for (int i = 0; i < 200 && st.current_count == 0; ++i) {
      (void)dds_get_subscription_matched_status(reader.id(), &st);
      if (st.current_count == 0) std::this_thread::sleep_for(5ms);
    }
    ASSERT_GT(st.current_count, 0u);
    expect_all_in_order(p, reader);
  }
}

// CiA 301 §7.2.8.3.2 (heartbeat carries the NMT state): DeviceStatus is
// reliable and transient-local, so a reader that joins after the fact gets
// the current identity and state of the device at once.
// The first key member of every topic is the FNV-1a 64 hash of the gateway
// id (docs/dds.md), so subscribers can compute it; the published vectors of
// the FNV reference (Fowler/Noll/Vo) pin the function.
TEST(DdsPlugin, GatewayKeyIsFnv1a64OfTheGatewayId) {
  EXPECT_EQ(dds::gateway_key(""), 0xcbf29ce484222325ull);
  EXPECT_EQ(dds::gateway_key("a"), 0xaf63dc4c8601ec8cull);
  EXPECT_EQ(dds::gateway_key("foobar"), 0x85944171f73967e8ull);
  EXPECT_NE(dds::gateway_key("line-1"), dds::gateway_key("line-2"));
}

TEST(DdsPlugin, Cia301_7_2_8_3_2_LateJoinerGetsCurrentDeviceStatus) {
  Plugin p(base_config());
  p.host.announce(device(3, 0, 12, "lift"));
  cobridge_sample hb = header(3, 0, 12, COBRIDGE_SAMPLE_HEARTBEAT, 1);
  hb.nmt_state = COBRIDGE_NMT_PRE_OPERATIONAL;
  hb.online = 1;
  hb.valid = COBRIDGE_VALID_NMT_STATE;
  cobridge_sample hb2 = hb;
  hb2.sequence = 2;
  hb2.rx_timestamp_ns += 1000;
  hb2.nmt_state = COBRIDGE_NMT_OPERATIONAL;
  const cobridge_sample batch[] = {hb, hb2};
  p.host.deliver(batch);
  // The plugin writes from its own thread: wait until the second status is
  // out (a witness sees it) before the late reader joins.
  Reader witness(&cobridge_DeviceStatus_desc, "DeviceStatus", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL,
                 true);
  bool written = false;
  for (int i = 0; i < 100 && !written; ++i) {
    witness.take<cobridge_DeviceStatus>(1, [&](const cobridge_DeviceStatus& s) {
      written = written || s.nmt_state == COBRIDGE_NMT_OPERATIONAL;
    }, 50ms);
  }
  ASSERT_TRUE(written);

  // Joins only now.
  Reader late(&cobridge_DeviceStatus_desc, "DeviceStatus", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL,
              false, 1);
  std::vector<GotStatus> got;
  late.take<cobridge_DeviceStatus>(1, [&](const cobridge_DeviceStatus& s) { got.push_back(copy_status(s)); });
  ASSERT_EQ(got.size(), 1u);
  const GotStatus& st = got[0];
  EXPECT_EQ(st.name, "lift");
  EXPECT_EQ(st.bus_name, "can0");
  EXPECT_EQ(st.model, "RSC-2800");
  EXPECT_EQ(st.family, "novotechnik-rotary");
  EXPECT_EQ(st.unit, "deg");
  EXPECT_EQ(st.v.bus, 0);
  EXPECT_EQ(st.v.node_id, 12);
  EXPECT_EQ(st.v.vendor_id, 0x65u);
  EXPECT_EQ(st.v.product_code, 0x4711u);
  EXPECT_EQ(st.v.revision, 0x00010002u);
  EXPECT_EQ(st.v.serial, 123459u);
  EXPECT_EQ(st.v.nmt_state, COBRIDGE_NMT_OPERATIONAL);  // the latest, not the first
  EXPECT_TRUE(st.v.online);
  EXPECT_FALSE(st.v.stale);
  EXPECT_EQ(st.v.updated_ns, hb2.rx_timestamp_ns);
  EXPECT_EQ(st.v.gateway_key, dds::gateway_key(test_gateway()));
}

// A silenced device (CiA 301 §7.2.8.3.2 heartbeat lost): the gateway's STATUS
// sample makes DeviceStatus offline and stale, and EncoderSample carries the
// last values again flagged stale.
TEST(DdsPlugin, Cia301_7_2_8_3_2_OfflineDeviceShowsOfflineAndItsValuesStale) {
  Reader samples(&cobridge_EncoderSample_desc, "EncoderSample", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_VOLATILE,
                 true);
  Reader status(&cobridge_DeviceStatus_desc, "DeviceStatus", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL,
                true);
  Plugin p(base_config("sample_reliability = \"reliable\"\n"));
  p.host.announce(device(0, 0, 5, "axis 1"));
  const cobridge_sample value = tpdo(0, 0, 5, 41);
  cobridge_sample lost = header(0, 0, 5, COBRIDGE_SAMPLE_STATUS, 42);
  lost.valid = COBRIDGE_VALID_STATUS | COBRIDGE_VALID_NMT_STATE;
  lost.online = 0;
  lost.stale = 1;
  lost.nmt_state = COBRIDGE_NMT_OPERATIONAL;
  const cobridge_sample batch[] = {value, lost};
  p.host.deliver(batch);

  std::vector<GotSample> got;
  samples.take<cobridge_EncoderSample>(2, [&](const cobridge_EncoderSample& s) { got.push_back(copy_sample(s)); });
  ASSERT_EQ(got.size(), 2u);
  EXPECT_FALSE(got[0].v.stale);
  EXPECT_TRUE(got[1].v.stale);
  EXPECT_EQ(got[1].v.position, value.position);
  EXPECT_EQ(got[1].v.sequence_number, value.sequence);
  EXPECT_EQ(got[1].v.publish_timestamp_ns, lost.publish_timestamp_ns);

  // Announcement, then the change to offline + stale.
  std::vector<GotStatus> st;
  status.take<cobridge_DeviceStatus>(2, [&](const cobridge_DeviceStatus& s) { st.push_back(copy_status(s)); });
  ASSERT_EQ(st.size(), 2u);
  EXPECT_FALSE(st[1].v.online);
  EXPECT_TRUE(st[1].v.stale);
  EXPECT_EQ(st[1].v.updated_ns, lost.rx_timestamp_ns);
}

// CiA 301 §7.2.7 / J§1.8.1: an EMCY of a Novotechnik rotary encoder appears on
// EncoderEvent with the manual's text, and DeviceStatus keeps its code as the
// last error.
TEST(DdsPlugin, J_1_8_1_EmcyAppearsOnEncoderEventWithText) {
  Reader events(&cobridge_EncoderEvent_desc, "EncoderEvent", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_VOLATILE, true);
  Plugin p(base_config());
  p.host.announce(device(2, 0, 9, "turntable", "novotechnik-rotary"));
  p.host.announce(device(4, 0, 10, "ifm axis", "ifm-rm"));
  cobridge_sample emcy = header(2, 0, 9, COBRIDGE_SAMPLE_EMCY, 5);
  emcy.emcy_code = 0x9080;  // J§1.8.1: encoder CAM state changed
  emcy.emcy_register = 0x01;
  const std::uint8_t details[5] = {0x01, 0x00, 0x02, 0x00, 0x02};
  std::memcpy(emcy.emcy_data, details, 5);
  emcy.valid = COBRIDGE_VALID_EMCY;
  cobridge_sample generic = header(4, 0, 10, COBRIDGE_SAMPLE_EMCY, 6);
  generic.emcy_code = canopen::emcy_code::kLifeGuardHeartbeat;
  generic.emcy_register = 0x11;
  generic.valid = COBRIDGE_VALID_EMCY;
  const cobridge_sample batch[] = {emcy, generic};
  p.host.deliver(batch);

  std::vector<GotEvent> got;
  events.take<cobridge_EncoderEvent>(2, [&](const cobridge_EncoderEvent& e) { got.push_back(copy_event(e)); });
  ASSERT_EQ(got.size(), 2u);
  std::sort(got.begin(), got.end(), [](const GotEvent& a, const GotEvent& b) { return a.v.node_id < b.v.node_id; });

  EXPECT_EQ(got[0].v.node_id, 9);
  EXPECT_EQ(got[0].device_name, "turntable");
  EXPECT_EQ(got[0].v.code, 0x9080);
  EXPECT_EQ(got[0].v.error_register, 0x01);
  EXPECT_EQ(0, std::memcmp(got[0].v.data, details, 5));
  // The row of J§1.8.1 as the rotary family's module has it (tests/unit/families).
  EXPECT_EQ(got[0].text, "encoder CAM state changed (coded as 0x6300)");
  EXPECT_EQ(got[0].source, "J§1.8.1");
  EXPECT_FALSE(got[0].text.empty());
  EXPECT_EQ(got[0].v.sequence_number, 5u);
  EXPECT_EQ(got[0].v.rx_timestamp_ns, emcy.rx_timestamp_ns);

  // F§7.3: the ifm manual has no code table, so the CiA 301 text is given.
  EXPECT_EQ(got[1].v.node_id, 10);
  EXPECT_EQ(got[1].v.code, 0x8130);
  EXPECT_EQ(got[1].text, canopen::cia301_text(0x8130));
  EXPECT_EQ(got[1].source, "CiA 301");

  Reader status(&cobridge_DeviceStatus_desc, "DeviceStatus", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL,
                false, 1);
  std::vector<GotStatus> st;
  status.take<cobridge_DeviceStatus>(2, [&](const cobridge_DeviceStatus& s) { st.push_back(copy_status(s)); });
  ASSERT_EQ(st.size(), 2u);
  for (const auto& s : st) {
    EXPECT_EQ(s.v.last_emcy_code, s.v.node_id == 9 ? 0x9080 : 0x8130);
    EXPECT_NE(s.v.last_emcy_ns, 0u);
  }
}

// docs/dds.md "Configuration" (no CiA clause): a misspelt key is refused at
// create with a message naming it; the host reports kCreateFailed.
TEST(DdsPlugin, DocsDds_UnknownKeyIsRejectedWithItsName) {
  LogCapture log;
  pipeline::PluginHost host({kPlugin.parent_path(), test_gateway(), log.sink()});
  const Error err = host.load({"dds", "dds", kPlugin, "domian = 3\n"});
  EXPECT_EQ(err.code, pipeline::PluginErrc::kCreateFailed);
  EXPECT_NE(err.message.find("domian"), std::string::npos) << err.message;
  EXPECT_EQ(host.loaded_count(), 0u);

  const Error err2 = host.load({"dds", "dds", kPlugin, "sample_reliability = \"sometimes\"\n"});
  EXPECT_EQ(err2.code, pipeline::PluginErrc::kCreateFailed);
  EXPECT_NE(err2.message.find("sometimes"), std::string::npos) << err2.message;
}

// docs/dds.md "Configuration": topic_prefix is prepended to every topic name.
TEST(DdsPlugin, DocsDds_TopicPrefixNamesTheTopics) {
  Reader prefixed(&cobridge_EncoderSample_desc, "plant1_EncoderSample", DDS_RELIABILITY_RELIABLE,
                  DDS_DURABILITY_VOLATILE, true);
  Plugin p(base_config("topic_prefix = \"plant1_\"\nsample_reliability = \"reliable\"\nsample_depth = 8\n"));
  const cobridge_sample s[] = {tpdo(0, 0, 3, 1)};
  p.host.deliver(s);
  std::vector<GotSample> got;
  prefixed.take<cobridge_EncoderSample>(1, [&](const cobridge_EncoderSample& v) { got.push_back(copy_sample(v)); });
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].v.node_id, 3);
  EXPECT_EQ(got[0].device_name, "");  // never announced
}

// docs/dds.md "DeviceStatus" config_state (plugin.h ABI 6): a device
// announced CHANGED with its configuration contested (a writer kept
// changing an object after 3 restores) publishes DeviceStatus with
// CONFIG_CONTESTED; an announcement of a host older than ABI 6 (shorter
// struct_size) says as configured, whatever the bytes beyond it hold.
TEST(DdsPlugin, DocsDds_ConfigStateReachesDeviceStatus) {
  Reader status(&cobridge_DeviceStatus_desc, "DeviceStatus", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL,
                true);
  Plugin p(base_config());
  cobridge_device_info d = device(7, 0, 21, "fought over");
  p.host.announce(d);
  d.change = COBRIDGE_DEVICE_CHANGED;
  d.config_state = COBRIDGE_CONFIG_CONTESTED;
  p.host.announce(d);
  std::vector<GotStatus> st;
  status.take<cobridge_DeviceStatus>(2, [&](const cobridge_DeviceStatus& s) { st.push_back(copy_status(s)); });
  ASSERT_EQ(st.size(), 2u);
  EXPECT_EQ(st[0].v.config_state, cobridge_CONFIG_AS_CONFIGURED);
  EXPECT_EQ(st[1].v.config_state, cobridge_CONFIG_CONTESTED);
  d.struct_size = offsetof(cobridge_device_info, config_state);  // an ABI 5 host's announcement
  p.host.announce(d);
  st.clear();
  status.take<cobridge_DeviceStatus>(1, [&](const cobridge_DeviceStatus& s) { st.push_back(copy_status(s)); });
  ASSERT_EQ(st.size(), 1u);
  EXPECT_EQ(st[0].v.config_state, cobridge_CONFIG_AS_CONFIGURED);
}

// A removed device (cobridge_device_info change REMOVED) disposes its
// DeviceStatus instance, so subscribers drop it.
TEST(DdsPlugin, DocsDds_RemovedDeviceIsDisposed) {
  Reader status(&cobridge_DeviceStatus_desc, "DeviceStatus", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL,
                true);
  Plugin p(base_config());
  p.host.announce(device(6, 1, 20, "gone soon"));
  std::vector<GotStatus> st;
  status.take<cobridge_DeviceStatus>(1, [&](const cobridge_DeviceStatus& s) { st.push_back(copy_status(s)); });
  ASSERT_EQ(st.size(), 1u);
  p.host.announce(device(6, 1, 20, "gone soon", "novotechnik-rotary", COBRIDGE_DEVICE_REMOVED));
  bool disposed = false;
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (!disposed && std::chrono::steady_clock::now() < deadline) {
    // Cyclone 0.10.2 re-initialises as many loan pointers as the largest
    // take on this reader asked for (Reader::take uses 256), not maxs.
    void* buf[Reader::kMax] = {};
    dds_sample_info_t info[Reader::kMax];
    const int n = dds_take(status.id(), buf, info, Reader::kMax, Reader::kMax);
    for (int i = 0; i < n; ++i) {
      if (info[static_cast<std::size_t>(i)].instance_state == DDS_IST_NOT_ALIVE_DISPOSED) disposed = true;
    }
    if (n > 0) dds_return_loan(status.id(), buf, n);
    if (n <= 0) std::this_thread::sleep_for(5ms);
  }
  EXPECT_TRUE(disposed);
}

// Runs `cobridge watch` as a child process; returns its stdout.
class Child {
 public:
  explicit Child(const std::vector<std::string>& args) {
    int fds[2];
    if (::pipe(fds) != 0) return;
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, fds[1], 1);
    posix_spawn_file_actions_addclose(&fa, fds[0]);
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, args[0].c_str(), &fa, nullptr, argv.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&fa);
    ::close(fds[1]);
    reader_ = std::thread([this, fd = fds[0]] {
      char buf[4096];
      ssize_t n;
      while ((n = ::read(fd, buf, sizeof buf)) > 0) {
        std::lock_guard lock(mutex_);
        out_.append(buf, static_cast<std::size_t>(n));
      }
      ::close(fd);
      eof_ = true;
    });
  }
  ~Child() {
    if (pid_ > 0 && status_ < 0) {
      ::kill(pid_, SIGKILL);
      wait();
    }
    if (reader_.joinable()) reader_.join();
  }
  bool running() const { return pid_ > 0 && !eof_; }
  int wait() {
    int st = 0;
    if (pid_ > 0 && ::waitpid(pid_, &st, 0) == pid_) status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128;
    if (reader_.joinable()) reader_.join();
    return status_;
  }
  std::string out() {
    std::lock_guard lock(mutex_);
    return out_;
  }

 private:
  pid_t pid_ = -1;
  int status_ = -1;
  std::thread reader_;
  std::mutex mutex_;
  std::string out_;
  std::atomic<bool> eof_{false};
};

// `cobridge watch --count 3 --json` in another process, over loopback: the
// current DeviceStatus (transient-local, written before watch started) and
// EncoderSamples a publisher writes, printed with their values.
TEST(DdsPlugin, DocsDds_WatchPrintsWhatAPublisherWrote) {
  ASSERT_TRUE(fs::exists(kCli)) << kCli;
  Plugin p(base_config("sample_reliability = \"reliable\"\n"));
  p.host.announce(device(0, 0, 5, "axis \"1\""));  // a quote, to check JSON escaping

  Child watch({kCli.string(), "watch", "--domain", std::to_string(test_domain()), "--gateway", test_gateway(),
               "--json", "--count", "3", "--timeout", "20"});
  // The late joiner learns the status (transient-local) on its own: wait
  // for that line first, so the samples below cannot fill --count before it.
  ASSERT_TRUE(eventually([&] { return watch.out().find("\"topic\":\"DeviceStatus\"") != std::string::npos; }, 15s))
      << watch.out();
  // Samples are volatile: keep publishing until watch has seen enough. After
  // each, watch has up to a publish period to print (or to end, done); one
  // written before watch's reader matched is lost, and the next goes out.
  constexpr auto kPublishPeriod = 20ms;
  std::uint32_t seq = 0;
  const auto deadline = std::chrono::steady_clock::now() + 25s;
  while (watch.running() && std::chrono::steady_clock::now() < deadline) {
    const std::size_t printed = watch.out().size();
    const cobridge_sample s[] = {tpdo(0, 0, 5, ++seq)};
    p.host.deliver(s);
    (void)eventually([&] { return !watch.running() || watch.out().size() != printed; }, kPublishPeriod);
  }
  ASSERT_EQ(watch.wait(), 0) << watch.out();
  const std::string out = watch.out();
  std::istringstream lines(out);
  std::string line;
  int status_lines = 0, sample_lines = 0;
  while (std::getline(lines, line)) {
    if (line.find("\"topic\":\"DeviceStatus\"") != std::string::npos) {
      ++status_lines;
      EXPECT_NE(line.find("\"name\":\"axis \\\"1\\\"\""), std::string::npos) << line;
      EXPECT_NE(line.find("\"serial\":123456"), std::string::npos) << line;
    } else if (line.find("\"topic\":\"EncoderSample\"") != std::string::npos) {
      ++sample_lines;
      // The printed position is the one written for the printed sequence.
      const auto at = line.find("\"sequence\":");
      ASSERT_NE(at, std::string::npos) << line;
      const auto n = static_cast<std::uint32_t>(std::stoul(line.substr(at + 11)));
      const cobridge_sample want = tpdo(0, 0, 5, n);
      EXPECT_NE(line.find("\"position\":" + std::to_string(want.position) + ","), std::string::npos) << line;
      EXPECT_NE(line.find("\"speed\":" + std::to_string(want.speed) + ","), std::string::npos) << line;
      EXPECT_NE(line.find("\"gateway_id\":\"" + test_gateway() + "\""), std::string::npos) << line;
      EXPECT_NE(line.find("\"node_id\":5,"), std::string::npos) << line;
    } else {
      ADD_FAILURE() << "unexpected line: " << line;
    }
  }
  EXPECT_EQ(status_lines + sample_lines, 3) << out;
  EXPECT_EQ(status_lines, 1) << out;  // the late joiner learnt the status
}

}  // namespace

namespace {

// Takes from `reader` (any state) until `done` says so or `limit` passed;
// `each` sees every sample with its info. The same take size as Reader.
template <typename T>
bool take_until(dds_entity_t reader, const std::function<bool(const T&, const dds_sample_info_t&)>& each,
                std::chrono::milliseconds limit = 10s) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < deadline) {
    void* buf[Reader::kMax] = {};
    dds_sample_info_t info[Reader::kMax];
    const int n = dds_take(reader, buf, info, Reader::kMax, Reader::kMax);
    bool done = false;
    for (int i = 0; i < n && !done; ++i) {
      const auto idx = static_cast<std::size_t>(i);
      done = each(*static_cast<const T*>(buf[idx]), info[idx]);
    }
    if (n > 0) dds_return_loan(reader, buf, n);
    if (done) return true;
    if (n <= 0) std::this_thread::sleep_for(5ms);
  }
  return false;
}

}  // namespace

// docs/dds.md "Loss or silence": a subscriber can tell loss from silence.
// EncoderSample is numbered by the TPDOs of its device alone (kind_sequence):
// heartbeats, EMCYs and status samples in between, which the topic does not
// carry, leave no gap; EncoderEvent is numbered by the EMCYs alone.
TEST(DdsPlugin, DocsDds_EachTopicNumbersItsOwnSamplesWithoutGaps) {
  Reader samples(&cobridge_EncoderSample_desc, "EncoderSample", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_VOLATILE,
                 true);
  Reader events(&cobridge_EncoderEvent_desc, "EncoderEvent", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_VOLATILE, true);
  Plugin p(base_config("sample_reliability = \"reliable\"\nsample_depth = 1000\n"));
  p.host.announce(device(0, 0, 5, "axis 1"));
  constexpr std::uint32_t kTpdos = 300;
  std::uint32_t seq = 0, hb_seq = 0, emcy_seq = 0;
  std::vector<cobridge_sample> batch;
  for (std::uint32_t k = 1; k <= kTpdos; ++k) {
    cobridge_sample t = tpdo(0, 0, 5, ++seq);
    t.kind_sequence = k;
    t.valid |= COBRIDGE_VALID_KIND_SEQUENCE;
    batch.push_back(t);
    if (k % 10 == 0) {  // a heartbeat every 10 TPDOs, as at 100 ms / 10 ms
      cobridge_sample hb = header(0, 0, 5, COBRIDGE_SAMPLE_HEARTBEAT, ++seq);
      hb.kind_sequence = ++hb_seq;
      hb.nmt_state = COBRIDGE_NMT_OPERATIONAL;
      hb.valid = COBRIDGE_VALID_NMT_STATE | COBRIDGE_VALID_KIND_SEQUENCE;
      batch.push_back(hb);
    }
    if (k % 100 == 0) {
      cobridge_sample e = header(0, 0, 5, COBRIDGE_SAMPLE_EMCY, ++seq);
      e.kind_sequence = ++emcy_seq;
      e.emcy_code = 0x1000;
      e.valid = COBRIDGE_VALID_EMCY | COBRIDGE_VALID_KIND_SEQUENCE;
      batch.push_back(e);
    }
    if (batch.size() >= 32) {
      p.host.deliver(batch);
      batch.clear();
    }
  }
  p.host.deliver(batch);
  std::vector<std::uint32_t> got;
  samples.take<cobridge_EncoderSample>(kTpdos,
                                       [&](const cobridge_EncoderSample& s) { got.push_back(s.sequence_number); });
  ASSERT_EQ(got.size(), kTpdos);
  for (std::uint32_t i = 0; i < kTpdos; ++i) ASSERT_EQ(got[i], i + 1) << "gap or reorder at sample " << i;
  std::vector<std::uint32_t> ev;
  events.take<cobridge_EncoderEvent>(emcy_seq, [&](const cobridge_EncoderEvent& e) { ev.push_back(e.sequence_number); });
  EXPECT_EQ(ev, (std::vector<std::uint32_t>{1, 2, 3}));
  EXPECT_GT(seq, kTpdos) << "the per-device sequence counted the other kinds too";
}

// docs/dds.md "GatewayStatus": it names the gateway's process and counts its
// devices and buses; a clean stop disposes it, so subscribers see the gateway
// leave at once.
TEST(DdsPlugin, DocsDds_GatewayStatusCountsDevicesAndIsDisposedOnStop) {
  Reader gw(&cobridge_GatewayStatus_desc, "GatewayStatus", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL,
            false, 1);
  Plugin p(base_config());
  p.host.announce(device(0, 0, 5, "axis 1"));
  p.host.announce(device(1, 1, 7, "axis 2"));
  cobridge_sample hb = header(1, 1, 7, COBRIDGE_SAMPLE_HEARTBEAT, 1);
  hb.nmt_state = COBRIDGE_NMT_OPERATIONAL;
  hb.valid = COBRIDGE_VALID_NMT_STATE;
  p.host.deliver({&hb, 1});
  std::uint64_t incarnation = 0;
  const bool counted = take_until<cobridge_GatewayStatus>(gw.id(), [&](const auto& s, const auto& info) {
    if (!info.valid_data || test_gateway() != s.gateway_id) return false;
    EXPECT_EQ(s.gateway_key, dds::gateway_key(test_gateway()));
    EXPECT_EQ(s.pid, static_cast<std::uint32_t>(::getpid()));
    EXPECT_FALSE(s.duplicate_id);
    incarnation = s.incarnation;
    return s.devices == 2 && s.devices_online == 1 && s.buses == 2 && s.buses_online == 1;
  });
  ASSERT_TRUE(counted) << "GatewayStatus never showed 2 devices (1 online) on 2 buses (1 online)";
  EXPECT_NE(incarnation, 0u);
  p.host.stop_all();
  const bool disposed = take_until<cobridge_GatewayStatus>(gw.id(), [&](const auto& s, const auto& info) {
    return s.gateway_key == dds::gateway_key(test_gateway()) && info.instance_state == DDS_IST_NOT_ALIVE_DISPOSED;
  });
  EXPECT_TRUE(disposed);
}

// docs/dds.md "GatewayStatus" bus_health (plugin.h ABI 5 on_bus): each
// bus's CAN controller (ISO 11898-1 state, error counters, restarts) in
// the gateway's GatewayStatus, the latest per bus, in bus order.
TEST(DdsPlugin, DocsDds_GatewayStatusCarriesEachBusControllerHealth) {
  Reader gw(&cobridge_GatewayStatus_desc, "GatewayStatus", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL,
            false, 1);
  Plugin p(base_config());
  cobridge_bus_info b{};
  b.struct_size = sizeof b;
  b.bus_index = 1;
  b.bus_name = "line2";
  b.open = 1;
  b.state = COBRIDGE_CONTROLLER_UNKNOWN;
  p.host.announce_bus(b);
  b.bus_index = 0;
  b.bus_name = "line1";
  b.state = COBRIDGE_CONTROLLER_ERROR_PASSIVE;
  b.source = COBRIDGE_SOURCE_ERROR_FRAMES;
  b.counters_known = 1;
  b.tx_errors = 128;
  b.rx_errors = 4;
  b.restarts = 2;
  b.error_frames = 9;
  p.host.announce_bus(b);
  std::string seen;
  const bool told = take_until<cobridge_GatewayStatus>(gw.id(), [&](const auto& s, const auto& info) {
    if (!info.valid_data || test_gateway() != s.gateway_id || s.bus_health._length != 2) return false;
    const cobridge_BusHealth& h = s.bus_health._buffer[0];
    seen = std::string(h.bus_name) + " " + std::to_string(h.controller_state) + " " + h.source + " " +
           std::to_string(h.tx_errors) + "/" + std::to_string(h.rx_errors) + " restarts " +
           std::to_string(h.restarts) + " frames " + std::to_string(h.error_frames) + "; " +
           s.bus_health._buffer[1].bus_name + " " + std::to_string(s.bus_health._buffer[1].controller_state);
    return h.controller_state == cobridge_CONTROLLER_ERROR_PASSIVE;
  });
  ASSERT_TRUE(told) << "GatewayStatus never carried both buses' health; last: " << seen;
  EXPECT_EQ(seen, "line1 3 error frames 128/4 restarts 2 frames 9; line2 0");
  p.host.stop_all();
}

// `cobridge watch` in another process, a participant without credentials:
// exit 0 with a DeviceStatus line when it got one within 3 s, 3 otherwise.
// Another process because Cyclone delivers between participants of one
// process directly, whatever their security.
std::pair<int, std::string> plain_watch_status() {
  Child watch({kCli.string(), "watch", "--domain", std::to_string(test_domain()), "--gateway", test_gateway(),
               "--json", "--count", "1", "--timeout", "3"});
  const int rc = watch.wait();
  return {rc, watch.out()};
}

// OMG DDS Security 1.1, 8.8.1 (a secured participant's entities are checked
// against its permissions, 9.4.1.3) and 9.4.1.2 (the test governance admits
// no unauthenticated participant): with [security] the plugin starts
// secured as the gateway's identity, all its topics, writers and the
// GatewayStatus reader allowed, its start log says so, and a participant
// without credentials gets nothing from it; without the table the same
// participant gets DeviceStatus and the log says the topics are open.
TEST(DdsPlugin, OmgDdsSec11_8_8_1_SecurityTableSecuresTheOutputAndTheLogSaysSo) {
  ASSERT_TRUE(fs::exists(kCli)) << kCli;
  {
    Plugin open(base_config());
    open.host.announce(device(0, 0, 5, "axis 1"));
    const auto [rc, out] = plain_watch_status();
    EXPECT_EQ(rc, 0) << "an open output is read by anyone: " << out;
    EXPECT_NE(out.find("\"topic\":\"DeviceStatus\""), std::string::npos) << out;
    EXPECT_NE(open.log.all().find("DDS Security: off (any participant on the network may read the topics)"),
              std::string::npos)
        << open.log.all();
  }
  Plugin secured(base_config(dds::test::TestCa::get().table("gateway")));
  EXPECT_NE(secured.log.all().find("DDS Security: on, identity 'CN=gateway,O=cobridge test'"), std::string::npos)
      << secured.log.all();
  secured.host.announce(device(0, 0, 5, "axis 1"));
  const auto [rc, out] = plain_watch_status();
  EXPECT_EQ(rc, 3) << "count not reached";
  EXPECT_EQ(out, "") << "a participant without credentials got something from the secured output";
}

// A secured output joining a domain that a plain participant of the same
// process made crashed Cyclone 0.10.2 (SIGSEGV in its gc thread): the
// output refuses to start instead, saying why.
TEST(DdsPlugin, DocsDds_SecuredOutputWantsItsDomainToItselfInTheProcess) {
  Reader plain(&cobridge_DeviceStatus_desc, "DeviceStatus", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL,
               true);
  LogCapture log;
  pipeline::PluginHost host({kPlugin.parent_path(), test_gateway(), log.sink()});
  const Error err = host.load({"dds", "dds", kPlugin, base_config(dds::test::TestCa::get().table("gateway"))});
  ASSERT_FALSE(err) << err.to_string();
  EXPECT_FALSE(host.start_all().empty());
  EXPECT_EQ(host.started_count(), 0u);
  EXPECT_NE(log.all().find("already has a participant in this process"), std::string::npos) << log.all();
}

// OMG DDS Security 1.1, 9.4.1.3: an identity whose permissions grant no
// publication (reader-all subscribes only) cannot start the output; the
// error names the permissions document and the subject.
TEST(DdsPlugin, OmgDdsSec11_9_4_1_3_PermissionsWithoutPublishStopTheStart) {
  LogCapture log;
  pipeline::PluginHost host({kPlugin.parent_path(), test_gateway(), log.sink()});
  const Error err = host.load({"dds", "dds", kPlugin, base_config(dds::test::TestCa::get().table("reader-all"))});
  ASSERT_FALSE(err) << err.to_string();
  EXPECT_FALSE(host.start_all().empty());
  EXPECT_EQ(host.started_count(), 0u);
  EXPECT_NE(log.all().find("does not grant it to 'CN=reader-all,O=cobridge test'"), std::string::npos) << log.all();
}

// docs/dds.md "QoS": every writer offers liveliness AUTOMATIC with the
// configured lease, so a subscriber sees a dead gateway within the lease.
TEST(DdsPlugin, DocsDds_WritersOfferAutomaticLivelinessWithTheConfiguredLease) {
  Reader samples(&cobridge_EncoderSample_desc, "EncoderSample", DDS_RELIABILITY_BEST_EFFORT, DDS_DURABILITY_VOLATILE,
                 false);
  Reader gw(&cobridge_GatewayStatus_desc, "GatewayStatus", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL,
            false, 1);
  Plugin p(base_config("liveliness_lease_ms = 300\n"));
  for (const dds_entity_t reader : {samples.id(), gw.id()}) {
    bool checked = false;
    const auto deadline = std::chrono::steady_clock::now() + 10s;
    while (!checked && std::chrono::steady_clock::now() < deadline) {
      dds_instance_handle_t handles[8];
      const dds_return_t n = dds_get_matched_publications(reader, handles, 8);
      for (dds_return_t i = 0; i < n; ++i) {
        dds_builtintopic_endpoint_t* ep = dds_get_matched_publication_data(reader, handles[i]);
        if (ep == nullptr) continue;
        dds_liveliness_kind_t kind{};
        dds_duration_t lease = 0;
        ASSERT_TRUE(dds_qget_liveliness(ep->qos, &kind, &lease));
        EXPECT_EQ(kind, DDS_LIVELINESS_AUTOMATIC);
        EXPECT_EQ(lease, DDS_MSECS(300));
        dds_builtintopic_free_endpoint(ep);
        checked = true;
      }
      if (!checked) std::this_thread::sleep_for(10ms);
    }
    EXPECT_TRUE(checked) << "no writer matched";
  }
}

// docs/dds.md "Many gateways in one domain": a second gateway with the same id
// in the domain is detected by both (logged as an error naming the other's host
// and pid, and duplicate_id in their GatewayStatus); when it stops, the first
// one logs that it left.
TEST(DdsPlugin, DocsDds_DuplicateGatewayIdIsDetectedAndReported) {
  auto first = std::make_unique<Plugin>(base_config());
  // Both write the one instance of this gateway id: room for both samples.
  Reader gw(&cobridge_GatewayStatus_desc, "GatewayStatus", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL,
            false, 16);
  {
    Plugin second(base_config());
    const std::string want = "duplicate gateway.id '" + test_gateway() + "'";
    (void)eventually(
        [&] {
          return first->log.all().find(want) != std::string::npos && second.log.all().find(want) != std::string::npos;
        },
        10s);
    EXPECT_NE(first->log.all().find(want), std::string::npos) << first->log.all();
    EXPECT_NE(second.log.all().find(want), std::string::npos) << second.log.all();
    EXPECT_NE(second.log.all().find(" pid " + std::to_string(::getpid())), std::string::npos) << second.log.all();
    std::map<std::uint64_t, bool> flagged;  // incarnation -> duplicate_id seen
    take_until<cobridge_GatewayStatus>(gw.id(), [&](const auto& s, const auto& info) {
      if (info.valid_data && test_gateway() == s.gateway_id && s.duplicate_id) flagged[s.incarnation] = true;
      return flagged.size() == 2;
    });
    EXPECT_EQ(flagged.size(), 2u) << "both incarnations publish duplicate_id";
  }
  (void)eventually([&] { return first->log.all().find("has left the DDS domain") != std::string::npos; }, 10s);
  EXPECT_NE(first->log.all().find("has left the DDS domain"), std::string::npos) << first->log.all();
}

// docs/dds.md "Threads and cost": best-effort EncoderSample is written on the
// dispatcher thread with sample_path "auto": every sample arrives in order with
// its values (in-process delivery loses nothing), DeviceStatus still follows
// from the writer thread, and the stale re-publication comes from the
// dispatcher side.
TEST(DdsPlugin, DocsDds_DispatcherPathDeliversInOrderAndRepublishesStale) {
  Reader reader(&cobridge_EncoderSample_desc, "EncoderSample", DDS_RELIABILITY_BEST_EFFORT, DDS_DURABILITY_VOLATILE,
                true);
  Reader status(&cobridge_DeviceStatus_desc, "DeviceStatus", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL,
                true);
  Plugin p(base_config("sample_path = \"auto\"\n"));
  EXPECT_NE(p.log.all().find("samples written by the dispatcher"), std::string::npos) << p.log.all();
  expect_all_in_order(p, reader);

  // plugin.h: `sequence` counts every sample of the device, so the status
  // after TPDO 1500 is 1501 and the next TPDO 1502 (the plugin judges which
  // is newer by it: the status lane).
  cobridge_sample lost = header(0, 0, 5, COBRIDGE_SAMPLE_STATUS, 1501);
  lost.valid = COBRIDGE_VALID_STATUS | COBRIDGE_VALID_NMT_STATE;
  lost.stale = 1;
  lost.nmt_state = COBRIDGE_NMT_OPERATIONAL;
  p.host.deliver({&lost, 1});
  std::vector<GotSample> got;
  reader.take<cobridge_EncoderSample>(1, [&](const cobridge_EncoderSample& s) { got.push_back(copy_sample(s)); });
  ASSERT_EQ(got.size(), 1u);
  EXPECT_TRUE(got[0].v.stale);
  EXPECT_EQ(got[0].v.node_id, 5);
  EXPECT_EQ(got[0].v.sequence_number, 1500u) << "the last TPDO again, same number";
  EXPECT_EQ(got[0].device_name, "axis 1");
  const bool stale_status = take_until<cobridge_DeviceStatus>(status.id(), [](const auto& s, const auto& info) {
    return info.valid_data && s.node_id == 5 && s.stale;
  });
  EXPECT_TRUE(stale_status);
  // A TPDO after the stale declaration clears it in DeviceStatus.
  const cobridge_sample fresh = tpdo(0, 0, 5, 1502);
  p.host.deliver({&fresh, 1});
  const bool fresh_status = take_until<cobridge_DeviceStatus>(status.id(), [](const auto& s, const auto& info) {
    return info.valid_data && s.node_id == 5 && !s.stale;
  });
  EXPECT_TRUE(fresh_status);
}

// docs/dds.md "Configuration", sample_path: "writer-thread" keeps best-effort
// samples on the writer thread; "dispatcher" with reliable samples writes them
// on the dispatcher (max_blocking_time 0), every one arriving in order.
TEST(DdsPlugin, DocsDds_SamplePathWriterThreadAndReliableDispatcher) {
  {
    Reader reader(&cobridge_EncoderSample_desc, "EncoderSample", DDS_RELIABILITY_BEST_EFFORT, DDS_DURABILITY_VOLATILE,
                  true);
    Plugin p(base_config("sample_path = \"writer-thread\"\n"));
    EXPECT_NE(p.log.all().find("samples written by the writer thread"), std::string::npos) << p.log.all();
    expect_all_in_order(p, reader);
  }
  Reader reader(&cobridge_EncoderSample_desc, "EncoderSample", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_VOLATILE, true);
  Plugin p(base_config("sample_reliability = \"reliable\"\nsample_depth = 4000\nsample_path = \"dispatcher\"\n"));
  EXPECT_NE(p.log.all().find("samples written by the dispatcher"), std::string::npos) << p.log.all();
  expect_all_in_order(p, reader);
}

// CiA 301 §7.2.2 (PDO) and docs/dds.md (EncoderSample.device_name): a
// device's first sample, delivered right after its announcement, carries its
// name on both writing paths. The writer thread once applied announcements
// only before its look at the sample ring, so one made while it was busy lost
// the race to its own samples (found by CI: "axis 2" went out nameless).
TEST(DdsPlugin, AFirstSampleRightAfterItsAnnouncementCarriesTheName) {
  for (const char* path : {"writer-thread", "auto"}) {
    SCOPED_TRACE(path);
    Reader reader(&cobridge_EncoderSample_desc, "EncoderSample", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_VOLATILE,
                  true);
    Plugin p(base_config(std::string("sample_reliability = \"reliable\"\nsample_path = \"") + path + "\"\n"));
    constexpr std::uint16_t kDevices = 400;
    std::vector<std::string> names;
    for (std::uint16_t i = 0; i < kDevices; ++i) names.push_back("dev " + std::to_string(i));
    for (std::uint16_t i = 0; i < kDevices; ++i) {
      const auto bus = static_cast<std::uint8_t>(i / 100);
      const auto node = static_cast<std::uint8_t>(1 + i % 100);
      p.host.announce(device(i, bus, node, names[i].c_str()));
      const cobridge_sample s = tpdo(i, bus, node, 1);
      p.host.deliver({&s, 1});
    }
    std::size_t nameless = 0;
    std::size_t got = 0;
    reader.take<cobridge_EncoderSample>(kDevices, [&](const cobridge_EncoderSample& s) {
      ++got;
      const std::uint16_t i = static_cast<std::uint16_t>(s.bus * 100 + s.node_id - 1);
      if (i >= kDevices || names[i] != s.device_name) ++nameless;
    });
    EXPECT_EQ(got, kDevices);
    EXPECT_EQ(nameless, 0u) << "samples without (or with another) device name";
  }
}

// docs/dds.md "Many gateways in one domain": `partition` puts every
// writer in that DDS partition; a reader of the partition gets the samples,
// a reader of the default partition does not.
TEST(DdsPlugin, DocsDds_PartitionSeparatesReaders) {
  const dds_entity_t pp = dds_create_participant(static_cast<dds_domainid_t>(test_domain()), nullptr, nullptr);
  ASSERT_GT(pp, 0);
  const dds_entity_t topic = dds_create_topic(pp, &cobridge_EncoderSample_desc, "EncoderSample", nullptr, nullptr);
  dds_qos_t* part = dds_create_qos();
  dds_qset_partition1(part, "hall-3");
  const dds_entity_t sub = dds_create_subscriber(pp, part, nullptr);
  dds_delete_qos(part);
  dds_qos_t* rq = dds_create_qos();
  dds_qset_reliability(rq, DDS_RELIABILITY_BEST_EFFORT, 0);
  dds_qset_history(rq, DDS_HISTORY_KEEP_ALL, 0);
  const dds_entity_t in_partition = dds_create_reader(sub, topic, rq, nullptr);
  const dds_entity_t in_default = dds_create_reader(pp, topic, rq, nullptr);
  dds_delete_qos(rq);
  {
    Plugin p(base_config("partition = \"hall-3\"\n"));
    EXPECT_NE(p.log.all().find("partition 'hall-3'"), std::string::npos) << p.log.all();
    p.host.announce(device(0, 0, 5, "axis 1"));
    const cobridge_sample s = tpdo(0, 0, 5, 1);
    p.host.deliver({&s, 1});
    const bool got = take_until<cobridge_EncoderSample>(in_partition, [](const auto& v, const auto& info) {
      return info.valid_data && test_gateway() == v.gateway_id && v.sequence_number == 1;
    });
    EXPECT_TRUE(got) << "the reader of partition hall-3 got the sample";
    const bool leaked = take_until<cobridge_EncoderSample>(
        in_default, [](const auto& v, const auto& info) { return info.valid_data && test_gateway() == v.gateway_id; },
        300ms);
    EXPECT_FALSE(leaked) << "a reader of the default partition must not see it";
  }
  dds_delete(pp);
}

// A reliable EncoderSample reader in a participant of its own that takes
// only when the test does and has room for 10 samples: every reliable write
// to it waits its max_blocking_time once the room is used up (a
// stalled reader). The participant goes with the object.
struct StalledReader {
  dds_entity_t pp = dds_create_participant(static_cast<dds_domainid_t>(test_domain()), nullptr, nullptr);
  dds_entity_t reader = make(pp);
  StalledReader() = default;
  StalledReader(const StalledReader&) = delete;
  StalledReader& operator=(const StalledReader&) = delete;
  ~StalledReader() {
    if (pp > 0) dds_delete(pp);
  }
  static dds_entity_t make(dds_entity_t pp) {
    const dds_entity_t topic = dds_create_topic(pp, &cobridge_EncoderSample_desc, "EncoderSample", nullptr, nullptr);
    dds_qos_t* rq = dds_create_qos();
    dds_qset_reliability(rq, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
    dds_qset_history(rq, DDS_HISTORY_KEEP_ALL, 0);
    dds_qset_resource_limits(rq, 10, DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED);
    const dds_entity_t reader = dds_create_reader(pp, topic, rq, nullptr);
    dds_delete_qos(rq);
    return reader;
  }
};

// docs/dds.md "Threads and cost": a reliable subscriber that stops reading must
// not stall the dispatcher (which Modbus and the tap share). The reader keeps
// at most 10 samples and never takes, so the reliable writer's history fills
// and each write waits (max_blocking_time); the dispatcher side (on_samples)
// still hands over all 100 000 samples, and what the DDS side could not keep up
// with is dropped from the plugin's queue and counted, never waited for. The
// longest on_samples call is printed, not judged.
TEST(DdsPlugin, DocsDds_StalledReliableReaderDoesNotBlockTheDispatcher) {
  const StalledReader stalled_reader;
  ASSERT_GT(stalled_reader.reader, 0);
  std::string log;
  std::chrono::nanoseconds longest{0};
  {
    Plugin p(base_config("sample_reliability = \"reliable\"\nsample_depth = 10000\n"));
    p.host.announce(device(0, 0, 5, "axis 1"));
    dds_publication_matched_status_t st{};
    std::vector<cobridge_sample> batch;
    std::uint32_t seq = 0;
    for (int b = 0; b < 400; ++b) {
      batch.clear();
      for (int i = 0; i < 250; ++i) batch.push_back(tpdo(0, 0, 5, ++seq));
      const auto t0 = std::chrono::steady_clock::now();
      p.host.deliver(batch);
      longest = std::max(longest, std::chrono::steady_clock::now() - t0);
    }
    EXPECT_EQ(seq, 100000u) << "every batch was handed over";
    (void)st;
    p.host.stop_all();
    log = p.log.all();
  }
  std::printf("  longest on_samples (250 samples) with a stalled reliable reader: %.3f ms\n",
              static_cast<double>(longest.count()) / 1e6);
  // The DDS side fell behind and said so; the dispatcher did not wait for it.
  EXPECT_TRUE(log.find("dropped because the DDS writer fell behind") != std::string::npos ||
              log.find("queued samples not written at stop") != std::string::npos)
      << log;
}

// The value of one of the plugin's figures (ABI 3 stats), 0 when absent.
static std::uint64_t figure(const Plugin& p, const std::string& name) {
  for (const auto& out : p.host.stats())
    for (const auto& f : out.figures)
      if (f.name == name) return f.value;
  return 0;
}

// docs/dds.md "Threads and cost", sample_path "auto" (the default): the
// dispatcher writes EncoderSample itself; a write that finds the reliable
// history full goes to the writer thread, and so does every sample after it
// until the writer thread has written them (order kept), then the dispatcher
// writes directly again. The reader has room for 10 samples: batch A (100)
// fills it before anyone takes, then a thread takes every millisecond and batch
// B (100) comes while A's rest waits on the writer thread. Every sample is
// accounted (written or counted failed), what arrives is in order (B written
// directly while A's rest waits would overtake it), and batch C after the
// backlog goes out directly (no more spills) and arrives whole. How many of A
// and B arrive is printed, not judged: the writer thread waits at most 1 ms per
// sample for room, and the taker's pace decides how often that is enough (with
// sample_path "dispatcher" every write after the 10th fails at once).
TEST(DdsPlugin, DocsDds_AutoSpillsAFullReliableHistoryToTheWriterThreadInOrder) {
  const StalledReader stalled_reader;
  ASSERT_GT(stalled_reader.reader, 0);
  const dds_entity_t reader = stalled_reader.reader;
  std::mutex m;
  std::vector<std::uint32_t> got;
  std::atomic<bool> taking{true};
  auto take_all = [&] {
    while (taking.load()) {
      (void)take_until<cobridge_EncoderSample>(reader, [&](const auto& v, const auto& info) {
        if (info.valid_data && test_gateway() == v.gateway_id) {
          std::lock_guard lock(m);
          got.push_back(v.sequence_number);
        }
        return false;
      }, 1ms);
    }
  };
  Plugin p(base_config("sample_reliability = \"reliable\"\nsample_depth = 10000\n"));
  EXPECT_NE(p.log.all().find("dispatcher (spilling to the writer thread)"), std::string::npos) << p.log.all();
  p.host.announce(device(0, 0, 5, "axis 1"));
  std::uint32_t seq = 0;
  auto deliver = [&](int n) {
    std::vector<cobridge_sample> batch;
    for (int i = 0; i < n; ++i) batch.push_back(tpdo(0, 0, 5, ++seq));
    p.host.deliver(batch);
  };
  auto accounted = [&] {
    return figure(p, "dds_samples_written") + figure(p, "dds_write_failures") + figure(p, "dds_samples_dropped");
  };
  auto wait_accounted = [&](std::uint64_t n) {
    (void)eventually([&] { return accounted() >= n; }, 10s);
    return accounted();
  };
  auto taken = [&] {
    std::lock_guard lock(m);
    return got.size();
  };
  deliver(100);
  std::thread taker(take_all);
  deliver(100);
  EXPECT_EQ(wait_accounted(200), 200u) << "every sample written or counted failed";
  const std::uint64_t spilled = figure(p, "dds_samples_spilled");
  EXPECT_GE(spilled, 1u) << "the full history sent samples to the writer thread";
  // The taker has every sample written: the reader is empty, the backlog gone.
  const std::uint64_t written = figure(p, "dds_samples_written");
  EXPECT_TRUE(eventually([&] { return taken() >= written; }, 10s)) << taken() << " of " << written << " taken";
  deliver(5);
  EXPECT_EQ(wait_accounted(205), 205u);
  EXPECT_EQ(figure(p, "dds_samples_spilled"), spilled) << "after the backlog the dispatcher writes directly again";
  auto has_last = [&] {
    std::lock_guard lock(m);
    return !got.empty() && got.back() == 205u;
  };
  (void)eventually(has_last, 5s);
  taking = false;
  taker.join();
  const std::uint64_t failed = figure(p, "dds_write_failures");
  p.host.stop_all();
  std::printf("  %zu of 205 samples arrived, %llu handed to the writer thread, %llu failed after waiting\n",
              got.size(), static_cast<unsigned long long>(spilled), static_cast<unsigned long long>(failed));
  EXPECT_EQ(got.size() + failed, 205u) << "what did not arrive was counted as failed";
  ASSERT_FALSE(got.empty());
  EXPECT_EQ(got.back(), 205u) << "batch C arrived";
  for (std::size_t i = 1; i < got.size(); ++i) ASSERT_LT(got[i - 1], got[i]) << "in order, at " << i;
  EXPECT_GE(got.size(), 15u) << "the first 10 and batch C at least";
}

// docs/dds.md "Threads and cost", sample_path "auto": a TPDO the dispatcher
// hands out more than DispatcherSamples::kBehindNs after its frame arrived (the
// dispatcher is behind) goes to the writer thread, and so does what follows
// until that has been written; then the dispatcher writes directly again. Every
// sample arrives, in order, with its values and name (the writer thread fills
// them from its own device table).
TEST(DdsPlugin, DocsDds_AutoHandsABacklogToTheWriterThread) {
  Reader reader(&cobridge_EncoderSample_desc, "EncoderSample", DDS_RELIABILITY_BEST_EFFORT, DDS_DURABILITY_VOLATILE,
                true);
  Plugin p(base_config());
  p.host.announce(device(0, 0, 5, "axis 1"));
  std::vector<cobridge_sample> late, on_time;
  for (std::uint32_t seq = 1; seq <= 300; ++seq) {
    cobridge_sample s = tpdo(0, 0, 5, seq);
    if (seq <= 200) s.publish_timestamp_ns = s.rx_timestamp_ns + 5'000'000;  // 5 ms behind
    (seq <= 200 ? late : on_time).push_back(s);
  }
  p.host.deliver(late);
  const std::uint64_t spilled = figure(p, "dds_samples_spilled");
  EXPECT_EQ(spilled, 200u) << "every late TPDO went to the writer thread";
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (figure(p, "dds_samples_written") < 200 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(2ms);
  p.host.deliver(on_time);
  EXPECT_EQ(figure(p, "dds_samples_spilled"), spilled) << "on time again: written on the dispatcher";
  std::vector<GotSample> got;
  reader.take<cobridge_EncoderSample>(300, [&](const cobridge_EncoderSample& v) { got.push_back(copy_sample(v)); });
  ASSERT_EQ(got.size(), 300u);
  for (std::size_t i = 0; i < got.size(); ++i) {
    expect_values(got[i], i < 200 ? late[i] : on_time[i - 200], "axis 1");
    if (::testing::Test::HasFailure()) return;
  }
}

// docs/dds.md "Many gateways in one domain" (a gateway that loses its bus) and
// "Threads and cost" (the status lane): a device going offline reaches
// DeviceStatus and GatewayStatus at once even with seconds of EncoderSamples
// queued before it. A reliable reader that never takes (room for 10 samples)
// makes every EncoderSample write wait its max_blocking_time, so 20 000 queued
// TPDOs are a backlog of about 20 s; the offline STATUS behind them must still
// be seen within 1 s (before the status lane it waited for the whole backlog:
// 2.5-4.8 s in UML, vcan_outputs_dds_multi_gateway).
TEST(DdsPlugin, DocsDds_OfflineIsNotQueuedBehindASampleBacklog) {
  const StalledReader stalled_reader;
  ASSERT_GT(stalled_reader.reader, 0);
  Reader status(&cobridge_DeviceStatus_desc, "DeviceStatus", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL,
                true);
  Reader gw(&cobridge_GatewayStatus_desc, "GatewayStatus", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL,
            false, 1);
  double offline_ms = -1, gateway_ms = -1;
  {
    Plugin p(base_config("sample_reliability = \"reliable\"\nsample_depth = 10000\n"));
    p.host.announce(device(0, 0, 5, "axis 1"));
    std::uint32_t seq = 0;
    cobridge_sample hb = header(0, 0, 5, COBRIDGE_SAMPLE_HEARTBEAT, ++seq);
    hb.nmt_state = COBRIDGE_NMT_OPERATIONAL;
    hb.valid = COBRIDGE_VALID_NMT_STATE;
    p.host.deliver({&hb, 1});
    std::vector<cobridge_sample> batch;
    for (int b = 0; b < 80; ++b) {
      batch.clear();
      for (int i = 0; i < 250; ++i) batch.push_back(tpdo(0, 0, 5, ++seq));
      p.host.deliver(batch);
    }
    cobridge_sample lost = header(0, 0, 5, COBRIDGE_SAMPLE_STATUS, ++seq);
    lost.valid = COBRIDGE_VALID_STATUS | COBRIDGE_VALID_NMT_STATE;
    lost.online = 0;
    lost.nmt_state = COBRIDGE_NMT_OPERATIONAL;
    const auto t0 = std::chrono::steady_clock::now();
    p.host.deliver({&lost, 1});
    auto ms_since = [&] {
      return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    };
    const bool offline = take_until<cobridge_DeviceStatus>(status.id(), [&](const auto& s, const auto& info) {
      return info.valid_data && test_gateway() == s.gateway_id && !s.online && s.updated_ns == lost.rx_timestamp_ns;
    }, 5s);
    if (offline) offline_ms = ms_since();
    const bool counted = take_until<cobridge_GatewayStatus>(gw.id(), [&](const auto& s, const auto& info) {
      return info.valid_data && test_gateway() == s.gateway_id && s.devices == 1 && s.devices_online == 0;
    }, 5s);
    if (counted) gateway_ms = ms_since();
    p.host.stop_all();
  }
  std::printf("  offline behind 20 000 queued samples: DeviceStatus after %.1f ms, GatewayStatus after %.1f ms\n",
              offline_ms, gateway_ms);
  EXPECT_GE(offline_ms, 0) << "DeviceStatus never showed the device offline";
  EXPECT_LE(offline_ms, 1000);
  EXPECT_GE(gateway_ms, 0) << "GatewayStatus never showed devices_online = 0";
  EXPECT_LE(gateway_ms, 1000);
}

namespace {

void tell_role(Plugin& p, std::uint8_t role, std::uint8_t own, std::uint8_t master) {
  static std::uint64_t since_ns = 1'800'000'000'000'000'000ull;
  since_ns += 5'000'000'000ull;  // each role change a few seconds after the last
  cobridge_role_info r{};
  r.since_ns = since_ns;
  r.struct_size = sizeof r;
  r.role = role;
  r.own_node = own;
  r.master_node = master;
  r.peer_node = own == 120 ? 121 : 120;
  r.bus_name = "can0";
  r.cause = role == COBRIDGE_ROLE_MASTER ? "no active master answered" : "an active master answered";
  p.host.announce_role(r);
}

// One TPDO from each gateway of the pair, told apart by their sequence
// numbers (a from 1, b from 100001: each gateway numbers its own samples).
void deliver_pair(Plugin* a, Plugin* b, std::uint32_t& k, int n) {
  for (int i = 0; i < n; ++i, ++k) {
    const cobridge_sample sa = tpdo(0, 0, 5, k), sb = tpdo(0, 0, 5, 100000 + k);
    if (a) a->host.deliver(std::span(&sa, 1));
    if (b) b->host.deliver(std::span(&sb, 1));
    std::this_thread::sleep_for(1ms);
  }
}

std::vector<std::uint32_t> drain(Reader& r, std::chrono::milliseconds quiet = 300ms) {
  std::vector<std::uint32_t> got;
  r.take<cobridge_EncoderSample>(
      1u << 20, [&](const cobridge_EncoderSample& s) { got.push_back(s.sequence_number); }, quiet);
  return got;
}

}  // namespace

// docs/dds.md, "A hot-standby pair" (DDS 1.4 2.2.3.9-10, OWNERSHIP and
// OWNERSHIP_STRENGTH): both gateways write the same instances with
// EXCLUSIVE ownership, the master stronger, so an EXCLUSIVE reader sees one
// stream: the master's; after a role change the new master's; when the
// master's writer is gone, the survivor's at once. Each gateway's
// GatewayStatus is its own instance and says its role.
TEST(DdsPlugin, HotStandbyPairReaderSeesTheMastersStreamOnly) {
  Reader samples(&cobridge_EncoderSample_desc, "EncoderSample", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_VOLATILE,
                 true, 1, DDS_OWNERSHIP_EXCLUSIVE);
  Reader gw(&cobridge_GatewayStatus_desc, "GatewayStatus", DDS_RELIABILITY_RELIABLE, DDS_DURABILITY_TRANSIENT_LOCAL,
            false, 1);
  auto a = std::make_unique<Plugin>(base_config("sample_reliability = \"reliable\"\n"), 120);
  auto b = std::make_unique<Plugin>(base_config("sample_reliability = \"reliable\"\n"), 121);
  a->host.announce(device(0, 0, 5, "axis 1"));
  b->host.announce(device(0, 0, 5, "axis 1"));
  tell_role(*a, COBRIDGE_ROLE_MASTER, 120, 120);
  tell_role(*b, COBRIDGE_ROLE_STANDBY, 121, 120);
  std::uint32_t k = 1;
  deliver_pair(a.get(), b.get(), k, 20);
  (void)drain(samples);  // discovery settles
  deliver_pair(a.get(), b.get(), k, 50);
  auto got = drain(samples);
  ASSERT_GE(got.size(), 45u);
  for (auto s : got) EXPECT_LT(s, 100000u) << "a sample of the standby reached an exclusive reader";

  EXPECT_NE(a->log.all().find(" (master)"), std::string::npos) << a->log.all();
  std::map<int, std::string> roles;  // redundancy_node -> role
  (void)take_until<cobridge_GatewayStatus>(gw.id(), [&](const auto& s, const auto& info) {
    if (info.valid_data && test_gateway() == s.gateway_id) {
      roles[s.redundancy_node] = s.role;
      EXPECT_FALSE(s.duplicate_id) << "the two gateways of a pair are not duplicates";
    }
    return roles[120] == "master" && roles[121] == "standby";
  });
  EXPECT_EQ(roles[120], "master");
  EXPECT_EQ(roles[121], "standby");

  // The roles change over: within a few samples the stream is b's.
  tell_role(*a, COBRIDGE_ROLE_STANDBY, 120, 121);
  tell_role(*b, COBRIDGE_ROLE_MASTER, 121, 121);
  deliver_pair(a.get(), b.get(), k, 60);
  got = drain(samples);
  ASSERT_GE(got.size(), 40u);
  for (std::size_t i = got.size() - 40; i < got.size(); ++i) EXPECT_GT(got[i], 100000u) << "at " << i;

  // The master dies (its writers go): the standby's stream follows at once,
  // in order, without a gap.
  b.reset();
  deliver_pair(a.get(), nullptr, k, 30);
  got = drain(samples);
  ASSERT_EQ(got.size(), 30u);
  for (std::size_t i = 1; i < got.size(); ++i) EXPECT_EQ(got[i], got[i - 1] + 1) << "gap at " << i;
}

