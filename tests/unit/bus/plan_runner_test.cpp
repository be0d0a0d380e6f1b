// PlanRunner against a scripted device: a canopen::SdoServer over an
// ObjectDictionary built from the family's shipped EDS (defaults resolved for
// the node-ID), an NMT state, and 'save' accepted only in pre-operational
// (J§1.10, E§11). Frames travel through a recording bus; a fake clock
// advances 1 ms per delivered frame and jumps to the runner's deadlines.
#include "bus/plan_runner.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "can/virtual_bus.hpp"
#include "canopen/nmt.hpp"
#include "canopen/object_dictionary.hpp"
#include "canopen/sdo_abort.hpp"
#include "canopen/sdo_client.hpp"
#include "canopen/sdo_server.hpp"
#include "device/eds.hpp"
#include "device/family_profile.hpp"
#include "device/sim_device.hpp"
#include "bus/config_plan.hpp"
#include "unit/device/source_paths.hpp"

namespace cobridge::bus {
namespace {

using namespace std::chrono_literals;
using canopen::TimePoint;
using config::Signal;

struct Bus final : can::FrameSink {
  std::deque<can::Frame> pending;
  std::vector<can::Frame> log;
  std::function<bool(const can::Frame&)> drop;  // true = lost on the wire
  bool send(const can::Frame& f) noexcept override {
    log.push_back(f);
    if (drop && drop(f)) return true;
    pending.push_back(f);
    return true;
  }
};

canopen::Access access_of(device::AccessType a) {
  switch (a) {
    case device::AccessType::kRo: return canopen::Access::kRo;
    case device::AccessType::kWo: return canopen::Access::kWo;
    case device::AccessType::kConst: return canopen::Access::kConst;
    default: return canopen::Access::kRw;
  }
}

bool is_text(device::DataType t) {
  return t == device::DataType::kVisibleString || t == device::DataType::kOctetString ||
         t == device::DataType::kDomain || t == device::DataType::kUnicodeString;
}

struct FakeDevice {
  FakeDevice(const device::DeviceDescription& eds, std::uint8_t node, Bus& bus) : node_id(node) {
    for (const device::ObjectDesc& e : eds.entries) {
      canopen::EntryDef def;
      def.index = e.index;
      def.sub = e.sub;
      def.type = static_cast<canopen::DataType>(static_cast<std::uint16_t>(e.data_type));
      def.access = access_of(e.access);
      def.pdo_mappable = e.pdo_mapping;
      def.name = e.name;
      if (is_text(e.data_type)) {
        def.text = e.default_value.text;
        def.capacity = std::max<std::uint32_t>(32, static_cast<std::uint32_t>(def.text.size()));
      } else if (device::is_signed_integer(e.data_type)) {
        def.value = e.default_signed_for_node(node).value_or(0);
      } else {
        def.value = e.default_for_node(node).value_or(0);
      }
      EXPECT_FALSE(od.insert(def)) << std::hex << e.index << "/" << int{e.sub};
    }
    for (std::uint8_t sub = 1; sub <= 5; ++sub) {
      if (!od.contains(0x1010, sub)) continue;
      canopen::Hooks h;
      h.on_write = [this](const canopen::WriteRequest& w) -> std::uint32_t {
        if (state != canopen::NmtState::pre_operational) return canopen::od_abort::kCannotStoreDeviceState;
        return w.raw == device::kSaveSignature ? 0u : canopen::od_abort::kCannotStore;
      };
      h.after_write = [this](std::uint16_t, std::uint8_t s) { saves.push_back(s); };
      EXPECT_FALSE(od.set_hooks(0x1010, sub, std::move(h)));
    }
    server = std::make_unique<canopen::SdoServer>(bus, od, node);
  }

  void on_frame(const can::Frame& f, TimePoint now) {
    if (f.id == 0) {
      const auto nmt = canopen::parse_nmt(f);
      if (nmt.ok() && nmt.frame.addresses(node_id)) {
        switch (nmt.frame.command) {
          case canopen::NmtCommand::enter_preop: state = canopen::NmtState::pre_operational; break;
          case canopen::NmtCommand::start: state = canopen::NmtState::operational; break;
          case canopen::NmtCommand::stop: state = canopen::NmtState::stopped; break;
          default: break;
        }
      }
      return;
    }
    server->on_frame(f, now);
  }

  std::uint8_t node_id;
  canopen::ObjectDictionary od;
  std::unique_ptr<canopen::SdoServer> server;
  canopen::NmtState state = canopen::NmtState::operational;
  std::vector<std::uint8_t> saves;
};

struct Fixture {
  explicit Fixture(const std::string& file, std::uint8_t node) {
    device::EdsResult r = device::load_eds_file(device::test::shipped_devices_dir() / file);
    EXPECT_TRUE(r.ok()) << file;
    eds = *r.description;
    profile = *device::family_profile_for(eds);
    dev = std::make_unique<FakeDevice>(eds, node, bus);
    canopen::SdoClient::Config cfg;
    cfg.timeout = 100ms;
    client = std::make_unique<canopen::SdoClient>(bus, node, cfg);
  }

  ConfigPlan plan(const config::Device& d) {
    auto r = make_config_plan(d, eds, profile, dev->node_id);
    for (const auto& e : r.errors) ADD_FAILURE() << e.to_string();
    return r.ok() ? *r.plan : ConfigPlan{};
  }

  // Runs a plan to the end; returns the index in bus.log where it began.
  PlanRunResult run(ConfigPlan p, PlanRunnerOptions options = {}) {
    first_frame = bus.log.size();
    PlanRunner runner(bus, *client, std::move(p), options);
    EXPECT_FALSE(runner.start(now));
    for (int guard = 0; guard < 100000 && !runner.finished(); ++guard) {
      while (!bus.pending.empty()) {
        const can::Frame f = bus.pending.front();
        bus.pending.pop_front();
        now += 1ms;
        dev->on_frame(f, now);
        runner.on_frame(f, now);
      }
      if (runner.finished()) break;
      const TimePoint d = runner.process(now);
      if (!bus.pending.empty() || runner.finished()) continue;
      if (d == canopen::kNever) {
        ADD_FAILURE() << "runner stalled";
        break;
      }
      now = std::max(now, d);
    }
    EXPECT_TRUE(runner.finished());
    return runner.result();
  }

  // SDO download requests (initiate) the run sent, in order.
  [[nodiscard]] std::vector<can::Frame> downloads() const {
    std::vector<can::Frame> out;
    for (std::size_t i = first_frame; i < bus.log.size(); ++i) {
      const can::Frame& f = bus.log[i];
      if (f.id == 0x600u + dev->node_id && (f.data[0] & 0xE0) == 0x20) out.push_back(f);
    }
    return out;
  }
  [[nodiscard]] std::vector<can::Frame> sdo_requests() const {
    std::vector<can::Frame> out;
    for (std::size_t i = first_frame; i < bus.log.size(); ++i)
      if (bus.log[i].id == 0x600u + dev->node_id) out.push_back(bus.log[i]);
    return out;
  }
  [[nodiscard]] std::vector<can::Frame> nmt() const {
    std::vector<can::Frame> out;
    for (std::size_t i = first_frame; i < bus.log.size(); ++i)
      if (bus.log[i].id == 0) out.push_back(bus.log[i]);
    return out;
  }

  Bus bus;
  device::DeviceDescription eds;
  device::FamilyProfile profile;
  std::unique_ptr<FakeDevice> dev;
  std::unique_ptr<canopen::SdoClient> client;
  TimePoint now{std::chrono::seconds{1000}};
  std::size_t first_frame = 0;
};

can::Frame sdo(std::uint8_t node, std::array<std::uint8_t, 8> bytes) {
  return can::Frame::make8(0x600u + node, bytes);
}

config::Device multiturn_settings() {
  config::Device d;
  d.name = "lift";
  d.tpdo1 = config::TpdoSettings{std::vector<config::MappingEntry>{{Signal::position, 0}, {Signal::speed, 0}},
                                 254, 100, std::nullopt};
  d.heartbeat_ms = 500;
  d.direction = config::Direction::ccw;
  d.preset = 1000;
  config::Cam cam;
  cam.index = 1;
  cam.low = 100;
  cam.high = 200;
  cam.enabled = true;
  d.cams.push_back(cam);
  d.work_area = config::WorkArea{std::nullopt, 50000};
  return d;
}

// First run on a factory-default multiturn device: writes, verifies, stores
// in pre-operational to /2 and /3 (E§11), starts. E§8.2 remap included.
TEST(PlanRunner, E11_FirstRunWritesAndStores) {
  Fixture fx("novotechnik-multiturn.eds", 5);
  const ConfigPlan plan = fx.plan(multiturn_settings());
  const PlanRunResult r = fx.run(plan);
  ASSERT_TRUE(r.ok()) << r.error.message;
  EXPECT_GT(r.writes, 8u);
  EXPECT_TRUE(r.stored);
  EXPECT_EQ(fx.dev->saves, (std::vector<std::uint8_t>{2, 3}));
  EXPECT_TRUE(r.started);
  EXPECT_EQ(fx.dev->state, canopen::NmtState::operational);
  const auto nmt = fx.nmt();
  ASSERT_EQ(nmt.size(), 2u);
  EXPECT_EQ(nmt.front(), can::Frame::make(0x000, {0x80, 0x05}));
  EXPECT_EQ(nmt.back(), can::Frame::make(0x000, {0x01, 0x05}));
  EXPECT_EQ(fx.bus.log.back(), nmt.back());
  auto& od = fx.dev->od;
  EXPECT_EQ(od.get_u8(0x1A00, 0), 2);
  EXPECT_EQ(od.get_u32(0x1A00, 1), 0x60040020u);
  EXPECT_EQ(od.get_u32(0x1800, 1), 0x40000185u);
  EXPECT_EQ(od.get_u16(0x1800, 5), 100);
  EXPECT_EQ(od.get_u16(0x1017, 0), 500);
  EXPECT_EQ(od.get_u8(0x6000, 0), 1);
  EXPECT_EQ(od.get_u32(0x6003, 0), 1000u);
  EXPECT_EQ(od.get_i32(0x6310, 1), 100);
  EXPECT_EQ(od.get_u8(0x6301, 1), 1);
  EXPECT_EQ(od.get_i32(0x6402, 1), 50000);
  // Per-step timings cover the whole run.
  ASSERT_EQ(r.steps.size(), plan.steps.size());
  canopen::Duration sum{};
  for (const auto& s : r.steps) sum += s.duration;
  EXPECT_EQ(sum, r.duration);
  EXPECT_GT(r.duration, 0ms);
}

// Flash wear (E§11): the same settings a second time read everything, write
// nothing and do not store.
TEST(PlanRunner, E11_UnchangedDeviceIsNotRewrittenOrStored) {
  Fixture fx("novotechnik-multiturn.eds", 5);
  const ConfigPlan plan = fx.plan(multiturn_settings());
  ASSERT_TRUE(fx.run(plan).ok());
  const PlanRunResult again = fx.run(plan);
  ASSERT_TRUE(again.ok()) << again.error.message;
  EXPECT_EQ(again.writes, 0u);
  EXPECT_FALSE(again.stored);
  EXPECT_GT(again.reads, 8u);
  EXPECT_TRUE(fx.downloads().empty());
  EXPECT_EQ(fx.dev->saves.size(), 2u);  // still only the first run's
  EXPECT_EQ(fx.plan(multiturn_settings()).fingerprint, plan.fingerprint);
}

// A changed event timer writes only 0x1800/5 and stores only the
// communication parameters (/2, E§11).
TEST(PlanRunner, E11_ChangedSettingWritesOnlyThatAndStores) {
  Fixture fx("novotechnik-multiturn.eds", 5);
  config::Device d = multiturn_settings();
  ASSERT_TRUE(fx.run(fx.plan(d)).ok());
  fx.dev->saves.clear();
  d.tpdo1->event_timer_ms = 200;
  const PlanRunResult r = fx.run(fx.plan(d));
  ASSERT_TRUE(r.ok()) << r.error.message;
  EXPECT_EQ(r.writes, 1u);
  EXPECT_TRUE(r.stored);
  EXPECT_EQ(fx.dev->saves, (std::vector<std::uint8_t>{2}));
  const auto w = fx.downloads();
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(w[0], sdo(5, {0x2B, 0x00, 0x18, 0x05, 0xC8, 0x00, 0x00, 0x00}));
  EXPECT_EQ(w[1], sdo(5, {0x23, 0x10, 0x10, 0x02, 0x73, 0x61, 0x76, 0x65}));  // E§7.1 'save'
}

// Store policy: always stores unchanged settings; never stores nothing.
TEST(PlanRunner, StorePolicyAlwaysAndNever) {
  Fixture fx("novotechnik-multiturn.eds", 5);
  config::Device d = multiturn_settings();
  d.store = config::StorePolicy::never;
  PlanRunResult r = fx.run(fx.plan(d));
  ASSERT_TRUE(r.ok()) << r.error.message;
  EXPECT_GT(r.writes, 0u);
  EXPECT_FALSE(r.stored);
  EXPECT_TRUE(fx.dev->saves.empty());
  d.store = config::StorePolicy::always;
  r = fx.run(fx.plan(d));
  ASSERT_TRUE(r.ok()) << r.error.message;
  EXPECT_EQ(r.writes, 0u);
  EXPECT_TRUE(r.stored);
  EXPECT_EQ(fx.dev->saves, (std::vector<std::uint8_t>{2, 3}));
}

// A value that does not stick fails verification with object and values;
// nothing is stored and the device is not started.
TEST(PlanRunner, ValueThatDoesNotStickFailsVerification) {
  Fixture fx("novotechnik-multiturn.eds", 5);
  canopen::Hooks h;
  h.after_write = [&fx](std::uint16_t, std::uint8_t) { (void)fx.dev->od.set_u32(0x6003, 0, 0); };
  ASSERT_FALSE(fx.dev->od.set_hooks(0x6003, 0, std::move(h)));
  const PlanRunResult r = fx.run(fx.plan(multiturn_settings()));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error.code, PlanRunErrc::verify_mismatch);
  EXPECT_EQ(r.error.message, "device 'lift': preset: 0x6003 written 0x000003E8 but read back 0x00000000");
  EXPECT_FALSE(r.stored);
  EXPECT_FALSE(r.started);
  EXPECT_TRUE(fx.dev->saves.empty());
  EXPECT_EQ(fx.dev->state, canopen::NmtState::pre_operational);
}

// An abort (E§7.3 0x06090030 "value exceeded") is reported with its code and
// text and not retried.
TEST(PlanRunner, E7_3_AbortReportedWithText) {
  Fixture fx("novotechnik-multiturn.eds", 5);
  canopen::Hooks h;
  h.on_write = [](const canopen::WriteRequest&) -> std::uint32_t { return 0x06090030; };
  ASSERT_FALSE(fx.dev->od.set_hooks(0x6001, 0, std::move(h)));
  config::Device d;
  d.name = "lift";
  d.scaling = config::Scaling{1u << 20, std::nullopt};
  const PlanRunResult r = fx.run(fx.plan(d));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error.code, PlanRunErrc::sdo_abort);
  EXPECT_EQ(r.sdo_error, canopen::SdoAbort::kInvalidValue);
  EXPECT_EQ(r.error.message,
            "device 'lift': scaling units_per_rev: writing 0x6001 = 0x00100000: SDO abort 0x06090030 (" +
                std::string(canopen::sdo_abort_text(0x06090030)) + ")");
  const auto w = fx.downloads();
  EXPECT_EQ(std::count_if(w.begin(), w.end(), [](const can::Frame& f) { return f.data[1] == 0x01 && f.data[2] == 0x60; }),
            1);
}

// CiA 301 §7.2.4.3: a lost request times out (0x05040000) and is repeated,
// at most sdo_retries times; a silent device ends with sdo_timeout.
TEST(PlanRunner, TimeoutRetriedThenReported) {
  Fixture fx("novotechnik-multiturn.eds", 5);
  int dropped = 0;
  fx.bus.drop = [&dropped](const can::Frame& f) {
    if (f.id == 0x605 && f.data[0] == 0x40 && f.data[1] == 0x17 && f.data[2] == 0x10 && dropped == 0) {
      ++dropped;
      return true;
    }
    return false;
  };
  config::Device d;
  d.name = "lift";
  d.heartbeat_ms = 250;
  PlanRunResult r = fx.run(fx.plan(d));
  ASSERT_TRUE(r.ok()) << r.error.message;
  EXPECT_EQ(r.retries, 1u);
  EXPECT_EQ(fx.dev->od.get_u16(0x1017, 0), 250);

  fx.bus.drop = [](const can::Frame& f) { return f.id == 0x605; };
  PlanRunnerOptions o;
  o.sdo_retries = 2;
  r = fx.run(fx.plan(d), o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error.code, PlanRunErrc::sdo_timeout);
  EXPECT_EQ(r.sdo_error, canopen::SdoAbort::kProtocolTimedOut);
  EXPECT_NE(r.error.message.find("device 'lift': heartbeat_ms: reading 0x1017: no answer after 3 attempts"),
            std::string::npos)
      << r.error.message;
  const auto requests = fx.sdo_requests();
  EXPECT_EQ(std::count_if(requests.begin(), requests.end(), [](const can::Frame& f) { return f.data[0] == 0x40; }),
            3);
}

// J§1.7.2 (and E§8.2): COB-ID bit 31 set keeping the RTR bit 30, 0x1A00/0 =
// 0, the entries, the count, bit 31 cleared, as consecutive downloads; the
// entry frame is the manual's `23 00 1A 01 20 01 20 60`.
TEST(PlanRunner, J1_7_2_RemapFollowsTheManualOrder) {
  Fixture fx("novotechnik-rfc4800-1ch.eds", 7);
  config::Device d;
  d.name = "arm";
  d.store = config::StorePolicy::never;
  d.tpdo1 = config::TpdoSettings{};
  d.tpdo1->mapping = std::vector<config::MappingEntry>{{Signal::position, 0}, {Signal::cam, 0}, {Signal::work_area, 0}};
  const PlanRunResult r = fx.run(fx.plan(d));
  ASSERT_TRUE(r.ok()) << r.error.message;
  const std::vector<can::Frame> expected{
      sdo(7, {0x23, 0x00, 0x18, 0x01, 0x87, 0x01, 0x00, 0xC0}),
      sdo(7, {0x2F, 0x00, 0x1A, 0x00, 0x00, 0x00, 0x00, 0x00}),
      sdo(7, {0x23, 0x00, 0x1A, 0x01, 0x20, 0x01, 0x20, 0x60}),
      sdo(7, {0x23, 0x00, 0x1A, 0x02, 0x08, 0x01, 0x00, 0x63}),
      sdo(7, {0x23, 0x00, 0x1A, 0x03, 0x08, 0x01, 0x00, 0x64}),
      sdo(7, {0x2F, 0x00, 0x1A, 0x00, 0x03, 0x00, 0x00, 0x00}),
      sdo(7, {0x23, 0x00, 0x18, 0x01, 0x87, 0x01, 0x00, 0x40}),
  };
  EXPECT_EQ(fx.downloads(), expected);
  // Nothing else reaches the SDO server between step 1 and step 5.
  const auto req = fx.sdo_requests();
  const auto first = std::find(req.begin(), req.end(), expected.front());
  ASSERT_NE(first, req.end());
  EXPECT_TRUE(std::equal(expected.begin(), expected.end(), first));
  EXPECT_EQ(r.writes, 7u);
  EXPECT_EQ(fx.dev->od.get_u32(0x1800, 1), 0x40000187u);
  EXPECT_EQ(fx.dev->od.get_u8(0x1A00, 0), 3);

  // The same mapping again: read, compared, nothing written.
  const PlanRunResult again = fx.run(fx.plan(d));
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again.writes, 0u);
}

// J§1.2.2: a rotary device refusing 0x1017 gets node guarding instead.
TEST(PlanRunner, J1_2_2_HeartbeatRefusedFallsBackToGuarding) {
  Fixture fx("novotechnik-rfc4800-1ch.eds", 7);
  canopen::Hooks h;
  h.on_write = [](const canopen::WriteRequest&) -> std::uint32_t { return 0x08000000; };
  ASSERT_FALSE(fx.dev->od.set_hooks(0x1017, 0, std::move(h)));
  config::Device d;
  d.name = "arm";
  d.heartbeat_ms = 200;
  const PlanRunResult r = fx.run(fx.plan(d));
  ASSERT_TRUE(r.ok()) << r.error.message;
  EXPECT_TRUE(r.guarding_fallback);
  EXPECT_EQ(fx.dev->od.get_u16(0x100C, 0), 200);
  EXPECT_EQ(fx.dev->od.get_u8(0x100D, 0), 3);
  EXPECT_EQ(fx.dev->od.get_u16(0x1017, 0), 0);
  EXPECT_EQ(fx.dev->saves, (std::vector<std::uint8_t>{2}));  // J§1.10: communication parameters
}

// J§1.4.1: 0x6000 is read-modify-write; bit 1 (commissioning diagnostic)
// survives a direction + moving-average change.
TEST(PlanRunner, J1_4_1_OperatingParameterKeepsOtherBits) {
  Fixture fx("novotechnik-rfc4800-1ch.eds", 7);
  ASSERT_EQ(fx.dev->od.set_u16(0x6000, 0, 0x0002), 0u);
  config::Device d;
  d.name = "arm";
  d.direction = config::Direction::ccw;
  d.position_filter = 2;
  const PlanRunResult r = fx.run(fx.plan(d));
  ASSERT_TRUE(r.ok()) << r.error.message;
  EXPECT_EQ(fx.dev->od.get_u16(0x6000, 0), 0x2003);
  const auto w = fx.downloads();
  ASSERT_FALSE(w.empty());
  EXPECT_EQ(w[0], sdo(7, {0x2B, 0x00, 0x60, 0x00, 0x03, 0x20, 0x00, 0x00}));
  EXPECT_EQ(fx.dev->saves, (std::vector<std::uint8_t>{3}));  // J§1.10: application parameters
}

// F§7.4 0x3000: node-ID 10 is written as 9 (value + 1 = node-ID), stored
// with 0x1010/1 (F§7.3); no NMT start (the ID applies after a reset).
TEST(PlanRunner, F7_4_IfmNodeIdEncoding) {
  Fixture fx("ifm-rm8-rm9.eds", 32);
  ASSERT_EQ(fx.dev->od.get_u8(0x3000, 0), 0x1F);  // the EDS default: node 32
  auto plan = make_node_id_plan("wheel", fx.eds, fx.profile, 32, 10);
  ASSERT_TRUE(plan.ok());
  const PlanRunResult r = fx.run(*plan.plan);
  ASSERT_TRUE(r.ok()) << r.error.message;
  const auto w = fx.downloads();
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(w[0], sdo(32, {0x2F, 0x00, 0x30, 0x00, 0x09, 0x00, 0x00, 0x00}));
  EXPECT_EQ(w[1], sdo(32, {0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65}));
  EXPECT_EQ(fx.dev->od.get_u8(0x3000, 0), 9);
  EXPECT_EQ(fx.profile.decode_node_id(*fx.dev->od.get_u8(0x3000, 0)), 10);
  EXPECT_FALSE(r.started);
  for (const can::Frame& f : fx.nmt()) EXPECT_NE(f.data[0], 0x01);
}

// The caller may keep the device in pre-operational (no NMT start).
TEST(PlanRunner, NoStartWhenTheCallerSaysSo) {
  Fixture fx("novotechnik-multiturn.eds", 5);
  PlanRunnerOptions o;
  o.start_node = false;
  const PlanRunResult r = fx.run(fx.plan(multiturn_settings()), o);
  ASSERT_TRUE(r.ok()) << r.error.message;
  EXPECT_FALSE(r.started);
  EXPECT_EQ(fx.dev->state, canopen::NmtState::pre_operational);
  EXPECT_EQ(fx.nmt().size(), 1u);
}

// A busy SDO client is refused without sending anything.
TEST(PlanRunner, BusyClientRefused) {
  Fixture fx("novotechnik-multiturn.eds", 5);
  ASSERT_FALSE(fx.client->start_upload(0x1000, 0, fx.now));
  PlanRunner runner(fx.bus, *fx.client, fx.plan(multiturn_settings()));
  const std::size_t before = fx.bus.log.size();
  EXPECT_EQ(runner.start(fx.now).code, PlanRunErrc::sdo_busy);
  EXPECT_EQ(fx.bus.log.size(), before);
  EXPECT_FALSE(runner.running());
}

// CiA 301 §7.2.8.3.3: a device that boots up mid-transfer has forgotten it.
// The runner dropped then (the bus manager does so on the boot-up) must free
// the SDO client, so that the next plan on the same client starts at once
// rather than being refused as busy for ever.
TEST(PlanRunner, DroppedMidTransferFreesTheSdoClient) {
  Fixture fx("novotechnik-multiturn.eds", 5);
  {
    PlanRunner first(fx.bus, *fx.client, fx.plan(multiturn_settings()));
    ASSERT_FALSE(first.start(fx.now));
    (void)first.process(fx.now);  // NMT pre-operational, then the first SDO request
    ASSERT_TRUE(fx.client->busy());
    fx.bus.pending.clear();  // the device rebooted: no answer comes
  }
  EXPECT_FALSE(fx.client->busy());
  const PlanRunResult r = fx.run(fx.plan(multiturn_settings()));
  EXPECT_TRUE(r.ok()) << r.error.message;
  EXPECT_TRUE(r.started);
}

// ---------------------------------------------------------------------------
// The same plans against the simulator's device model (sim::SimDevice over
// can::VirtualBus), one per family.


struct SimRun {
  SimRun(const char* model, const std::string& eds_file) : device_port(bus.attach()), gateway_port(bus.attach()) {
    device::EdsResult r = device::load_eds_file(device::test::shipped_devices_dir() / eds_file);
    EXPECT_TRUE(r.ok()) << eds_file;
    eds = *r.description;
    profile = *device::family_profile_for(eds);
    sim::DeviceSpec spec;
    spec.model = sim::find_model(model);
    EXPECT_NE(spec.model, nullptr) << model;
    spec.serial = 4711;
    dev = std::make_unique<sim::SimDevice>(spec, eds, device_port, std::filesystem::path{});
    EXPECT_FALSE(dev->power_on(now));
    node = dev->node_id();
    canopen::SdoClient::Config cfg;
    cfg.timeout = 100ms;
    client = std::make_unique<canopen::SdoClient>(gateway_port, node, cfg);
  }

  PlanRunResult run(const config::Device& d) {
    auto plan = make_config_plan(d, eds, profile, node);
    for (const auto& e : plan.errors) ADD_FAILURE() << e.to_string();
    if (!plan.ok()) return {};
    PlanRunner runner(gateway_port, *client, *plan.plan);
    EXPECT_FALSE(runner.start(now));
    for (int guard = 0; guard < 100000 && !runner.finished(); ++guard) {
      can::Frame f;
      bool moved = false;
      while (device_port.receive(f)) {
        dev->on_frame(f, now);
        moved = true;
      }
      while (gateway_port.receive(f)) {
        runner.on_frame(f, now);
        moved = true;
      }
      if (moved) {
        now += 1ms;
        continue;
      }
      const TimePoint next = std::min(runner.process(now), dev->process(now));
      if (device_port.pending() > 0 || gateway_port.pending() > 0 || runner.finished()) continue;
      now = std::max(now + 1ms, next == canopen::kNever ? now + 1ms : next);
    }
    EXPECT_TRUE(runner.finished());
    can::Frame last;  // the NMT start is still on its way to the device
    while (device_port.receive(last)) dev->on_frame(last, now);
    gateway_port.clear();
    return runner.result();
  }

  can::VirtualBus bus;
  can::VirtualBus::Port& device_port;
  can::VirtualBus::Port& gateway_port;
  device::DeviceDescription eds;
  device::FamilyProfile profile;
  std::unique_ptr<sim::SimDevice> dev;
  std::unique_ptr<canopen::SdoClient> client;
  std::uint8_t node = 0;
  TimePoint now{std::chrono::seconds{1000}};
};

void first_and_second_run(SimRun& s, const config::Device& d) {
  const PlanRunResult first = s.run(d);
  ASSERT_TRUE(first.ok()) << first.error.message;
  EXPECT_GT(first.writes, 0u);
  EXPECT_TRUE(first.stored);
  EXPECT_EQ(s.dev->nmt_state(), canopen::NmtState::operational);
  const PlanRunResult second = s.run(d);
  ASSERT_TRUE(second.ok()) << second.error.message;
  EXPECT_EQ(second.writes, 0u);
  EXPECT_FALSE(second.stored);
}

// E§8.2, E§5.3, E§11 on the simulated multiturn device.
TEST(PlanRunnerSim, E8_2_MultiturnFirstRunThenNothing) {
  SimRun s("MC1-2800", "novotechnik-multiturn.eds");
  config::Device d = multiturn_settings();
  d.scaling = config::Scaling{4096, std::nullopt};
  first_and_second_run(s, d);
  const canopen::ObjectDictionary* od = s.dev->object_dictionary();
  ASSERT_NE(od, nullptr);
  EXPECT_EQ(od->get_u32(0x1A00, 1), 0x60040020u);
  EXPECT_EQ(od->get_u32(0x6001, 0), 4096u);
}

// J§1.7.2, J§1.4.1 on the simulated rotary device.
TEST(PlanRunnerSim, J1_7_2_RotaryFirstRunThenNothing) {
  SimRun s("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  config::Device d;
  d.name = "arm";
  d.tpdo1 = config::TpdoSettings{std::vector<config::MappingEntry>{{Signal::position, 0}, {Signal::cam, 0}},
                                 254, 20, std::nullopt};
  d.heartbeat_ms = 100;
  d.direction = config::Direction::ccw;
  d.position_filter = 1;
  d.preset = 10;
  first_and_second_run(s, d);
}

// F§7.3 / F§7.4 on the simulated ifm device.
TEST(PlanRunnerSim, F7_4_IfmFirstRunThenNothing) {
  SimRun s("RM9000", "ifm-rm8-rm9.eds");
  config::Device d;
  d.name = "wheel";
  d.tpdo1 = config::TpdoSettings{std::vector<config::MappingEntry>{{Signal::position, 0}}, 254, 50, std::nullopt};
  d.heartbeat_ms = 100;
  d.preset = 10;
  config::Cam cam;
  cam.index = 8;
  cam.low = 5;
  cam.enabled = true;
  d.cams.push_back(cam);
  first_and_second_run(s, d);
}

}  // namespace
}  // namespace cobridge::bus
