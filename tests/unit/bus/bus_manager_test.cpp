// The bus controller's decisions on a virtual bus (VirtualLine: BusManager
// stepped, the simulator's encoders, a fake clock): commissioning, plans,
// supervision and their faults, each in milliseconds of CPU and no sleep.
// The end-to-end tests in tests/vcan/daemon run the same decisions on
// SocketCAN in a VM, with the real daemon and timing bounds.
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <string>

#include "canopen/cob_id.hpp"
#include "unit/bus/virtual_line.hpp"

namespace cobridge::bus::test {
namespace {

const char* const kBus = "bitrate = 250\ndiscovery_period_s = 30\nnode_pool = \"40-60\"\n";

std::string device_toml(const char* name, const char* model, std::uint32_t serial, int node,
                        int heartbeat_ms = 100) {
  return "[[device]]\nname = \"" + std::string(name) + "\"\nbus = \"line1\"\nmodel = \"" + model +
         "\"\nserial = " + std::to_string(serial) + "\nnode_id = " + std::to_string(node) +
         "\nheartbeat_ms = " + std::to_string(heartbeat_ms) +
         "\n[device.tpdo1]\nmapping = [\"position\"]\ntransmission = \"event\"\nevent_timer_ms = 100\n\n";
}

// TPDO1 frames of `node` on the bus since frame `from` of its log: values flow.
std::size_t tpdo1_frames(can::VirtualBus& bus, std::uint8_t node, std::size_t from = 0) {
  const auto& log = bus.log();
  return static_cast<std::size_t>(std::count_if(log.begin() + static_cast<std::ptrdiff_t>(from), log.end(),
                                                [&](const can::Frame& f) { return f.id == 0x180U + node; }));
}

// CiA 301 §7.2.4.3.3 expedited download of 2 bytes, as another client sends it.
can::Frame sdo_write_u16(std::uint8_t node, std::uint16_t index, std::uint8_t sub, std::uint16_t value) {
  can::Frame f;
  f.id = 0x600U + node;
  f.len = 8;
  f.data = {0x2B, static_cast<std::uint8_t>(index), static_cast<std::uint8_t>(index >> 8), sub,
            static_cast<std::uint8_t>(value), static_cast<std::uint8_t>(value >> 8), 0, 0};
  return f;
}

can::Frame heartbeat(std::uint8_t node, std::uint8_t state) {
  can::Frame f;
  f.id = 0x700U + node;
  f.len = 1;
  f.data[0] = state;
  return f;
}

can::Frame nmt(std::uint8_t command, std::uint8_t node) {
  can::Frame f;
  f.id = 0;
  f.len = 2;
  f.data[0] = command;
  f.data[1] = node;
  return f;
}

bool is_download(const can::Frame& f, std::uint8_t node) {
  return f.id == 0x600U + node && (f.data[0] & 0xE0) == 0x20;
}

std::size_t sdo_downloads(can::VirtualBus& bus, std::uint8_t node) {
  const auto& log = bus.log();
  return static_cast<std::size_t>(std::count_if(log.begin(), log.end(), [&](const can::Frame& f) { return is_download(f, node); }));
}

// Downloads of 0x1017 to `node` since frame `from`, whoever sent them.
std::size_t heartbeat_writes(can::VirtualBus& bus, std::uint8_t node, std::size_t from) {
  const auto& log = bus.log();
  return static_cast<std::size_t>(std::count_if(log.begin() + static_cast<std::ptrdiff_t>(from), log.end(), [&](const can::Frame& f) {
    return is_download(f, node) && f.data[1] == 0x17 && f.data[2] == 0x10;
  }));
}

// One multiturn (E) configured as mt-a at node 20, another SDO client's
// port beside it; most scenarios start from here.
struct OneMultiturn {
  explicit OneMultiturn(int heartbeat_ms = 100)
      : line(kBus, device_toml("mt-a", "MC1-2800", 2001, 20, heartbeat_ms)),
        dev(line.add_device("MC1-2800", 2001, 20)),
        other(line.bus().attach()) {}
  // Started; true once mt-a is operational (within `limit` of bus time).
  bool operational(std::chrono::milliseconds limit = 5s) {
    line.start();
    return line.run_until(VirtualLine::all_in(DeviceState::operational), limit).has_value();
  }
  [[nodiscard]] std::string why() const {
    const auto d = line.device("mt-a");
    return std::string(to_string(d->state)) + ": " + d->last_error;
  }
  // True once the device's own 0x1017 holds `ms` (within `limit`).
  bool heartbeat_becomes(std::uint16_t ms, std::chrono::milliseconds limit) {
    return line
        .run_until([&](const BusStatus&) { return dev.object_dictionary()->get_u16(0x1017, 0) == std::optional(ms); },
                   limit)
        .has_value();
  }

  VirtualLine line;
  sim::SimDevice& dev;
  can::VirtualBus::Port& other;
};

// CiA 305 Fastscan (E§6): two multiturns of the same model, both
// non-configured (FFh), get the node-IDs their serials are configured with,
// remembered in the state file; then their TPDOs flow.
TEST(BusManagerLine, Cia305_TwoMultiturnsAtFFhCommissionedAndOperational) {
  VirtualLine line(kBus, device_toml("mt-a", "MC1-2800", 2001, 20) + device_toml("mt-b", "MC1-2800", 2002, 21));
  line.add_device("MC1-2800", 2001, 0xFF);
  line.add_device("MC1-2800", 2002, 0xFF);
  line.start();
  const auto took = line.run_until(VirtualLine::all_in(DeviceState::operational), 10s);
  ASSERT_TRUE(took) << "not all operational in 10 s of bus time";
  EXPECT_LT(*took, 3s) << "commissioning target (docs/performance.md)";
  EXPECT_EQ(line.device("mt-a")->node_id, 20);
  EXPECT_EQ(line.device("mt-b")->node_id, 21);
  EXPECT_EQ(line.store().on_bus("line1").size(), 2u);
  const std::size_t mark = line.bus().log().size();
  line.run_for(1s);
  EXPECT_GE(tpdo1_frames(line.bus(), 20, mark), 8u);
  EXPECT_GE(tpdo1_frames(line.bus(), 21, mark), 8u);
}

// J§1.2.2: rotary encoders ship at node-ID 127; two at once clash there and
// are told apart by their serials (LSS), each moved to its configured node.
TEST(BusManagerLine, J1_2_2_TwoRotaryClashingAt127Resolved) {
  VirtualLine line(kBus, device_toml("rot-a", "RFC-4800", 1001, 10) + device_toml("rot-b", "RFC-4800", 1002, 11));
  line.add_device("RFC-4800", 1001);
  line.add_device("RFC-4800", 1002);
  line.start();
  ASSERT_TRUE(line.run_until(VirtualLine::all_in(DeviceState::operational), 15s));
  EXPECT_EQ(line.device("rot-a")->node_id, 10);
  EXPECT_EQ(line.device("rot-b")->node_id, 11);
}

// CiA 301 §7.2.8.3.2.2 heartbeat consumer: a device that falls silent is
// offline within its consumer time (status says so), and once it talks
// again it is checked and operational, its values flowing.
TEST(BusManagerLine, Cia301_7_2_8_3_HeartbeatLostThenBack) {
  OneMultiturn t;
  ASSERT_TRUE(t.operational());
  t.dev.set_silent(true);
  const auto lost = t.line.run_until(VirtualLine::is("mt-a", DeviceState::offline), 2s);
  ASSERT_TRUE(lost) << "still " << t.why();
  EXPECT_LE(*lost, 500ms) << "consumer time of a 100 ms heartbeat";
  EXPECT_FALSE(t.line.device("mt-a")->online);
  t.dev.set_silent(false);
  ASSERT_TRUE(t.line.run_until(VirtualLine::is("mt-a", DeviceState::operational), 3s));
  const std::size_t mark = t.line.bus().log().size();
  t.line.run_for(500ms);
  EXPECT_GE(tpdo1_frames(t.line.bus(), 20, mark), 3u);
}

// A device that reboots in the middle of its configuration (boot-up mid
// plan, E§8.2): the plan that was running is dropped, the device is
// configured again from the start and ends operational.
TEST(BusManagerLine, E8_2_PowerCycleMidPlanEndsConfigured) {
  OneMultiturn t;
  t.line.start();
  ASSERT_TRUE(t.line.run_until(VirtualLine::is("mt-a", DeviceState::configuring), 2s));
  t.dev.reboot_on_sdo(3);  // the plan's third request from now
  ASSERT_TRUE(t.line.run_until(VirtualLine::all_in(DeviceState::operational), 10s)) << t.why();
  t.line.run_for(10ms);  // the NMT start on its way
  EXPECT_EQ(t.dev.nmt_state(), canopen::NmtState::operational);
  EXPECT_GE(t.line.device("mt-a")->boot_ups, 1u) << "the reboot was seen";
}

// A reboot while discovery reads the identity (0x1018, CiA 301 §7.5.2.35)
// is one device rebooting, not two devices at one node-ID: no clash is
// reported, and the device ends operational.
TEST(BusManagerLine, RebootDuringTheIdentityReadIsNoClash) {
  for (std::uint32_t nth = 1; nth <= 4; ++nth) {
    const LogCapture log;
    OneMultiturn t;
    t.dev.reboot_on_sdo(nth);
    ASSERT_TRUE(t.operational(10s)) << "reboot on request " << nth;
    EXPECT_EQ(log.count("devices answer at node"), 0u) << "reboot on request " << nth;
  }
}

// An SDO request the device leaves unanswered (CiA 301 §7.2.4.3.17 abort
// 0x05040000, SDO protocol timed out): the run fails, is tried again, and
// the device ends operational.
TEST(BusManagerLine, Cia301_SdoTimeoutRetriedThenOperational) {
  OneMultiturn t;
  t.dev.ignore_sdo(0x1017, 1);
  ASSERT_TRUE(t.operational(10s)) << t.why();
  EXPECT_EQ(t.dev.object_dictionary()->get_u16(0x1017, 0), std::optional<std::uint16_t>(100));
}

// CiA 301 §7.2.4.3.17 SDO abort during the plan: the run fails, is tried
// again after its delay, and the device ends operational.
TEST(BusManagerLine, Cia301_7_2_4_3_17_SdoAbortRetriedThenOperational) {
  OneMultiturn t;
  t.dev.abort_sdo(0x1017, 0x08000020);  // data cannot be stored
  ASSERT_TRUE(t.operational(10s)) << t.why();
  EXPECT_EQ(t.dev.object_dictionary()->get_u16(0x1017, 0), std::optional<std::uint16_t>(100));
}

// A heartbeat the device sent before it took the NMT start (CiA 301
// §7.2.8.3.2.2: state 7Fh) read after the start was sent (a loaded
// gateway's socket held it): stale, not a device put back to
// pre-operational; no reconfiguration. The same state heard after the
// settle is news: the device is started again.
TEST(BusManagerLine, Cia301_StaleHeartbeatAfterTheStartIsNoReconfiguration) {
  const LogCapture log;
  OneMultiturn t;
  ASSERT_TRUE(t.operational());
  ASSERT_TRUE(t.other.send(heartbeat(20, 0x7F)));  // the one sent before the start, read now
  t.line.run_for(2s);
  EXPECT_EQ(log.count("pre-operational again"), 0u);
  EXPECT_EQ(t.line.device("mt-a")->state, DeviceState::operational);
  // Really put back (another master's NMT enter pre-operational): started again.
  ASSERT_TRUE(t.other.send(nmt(0x80, 20)));
  ASSERT_TRUE(t.line.run_until([&](const BusStatus&) { return log.count("pre-operational again") == 1; }, 2s));
  ASSERT_TRUE(t.line.run_until(
      [&](const BusStatus&) { return t.dev.nmt_state() == canopen::NmtState::operational; }, 3s));
}

// Started with the device leaving its first `ignored` NMT starts unacted;
// true once the device itself is operational within `limit`.
bool device_started_despite(OneMultiturn& t, std::uint32_t ignored, std::chrono::milliseconds limit) {
  t.dev.ignore_nmt_start(ignored);
  t.line.start();
  return t.line
      .run_until([&](const BusStatus&) { return t.dev.nmt_state() == canopen::NmtState::operational; }, limit)
      .has_value();
}

// A device that does not act on the plan's NMT start (CiA 301 §7.2.8.3.1;
// missed, or slow: the simulator under a sanitizer on a loaded guest), its
// heartbeats still saying pre-operational: the start is sent again, not the
// whole plan (which, started anew per late heartbeat, never ended there).
TEST(BusManagerLine, Cia301_StartNotActedOnIsSentAgainNotReplanned) {
  const LogCapture log;
  OneMultiturn t;
  ASSERT_TRUE(device_started_despite(t, 2, 5s)) << t.why();
  EXPECT_EQ(log.count("start sent again"), 2u);
  EXPECT_EQ(log.count("pre-operational again"), 0u);
  const std::size_t downloads = sdo_downloads(t.line.bus(), 20);
  t.line.run_for(2s);
  EXPECT_EQ(t.line.device("mt-a")->state, DeviceState::operational) << t.why();
  EXPECT_EQ(sdo_downloads(t.line.bus(), 20), downloads);
}

// One that keeps ignoring it past the resends: the whole plan after all,
// then operational (a device that missed a reset's boot-up looks so too).
TEST(BusManagerLine, Cia301_StartIgnoredPastTheResendsIsReplanned) {
  const LogCapture log;
  OneMultiturn t;
  ASSERT_TRUE(device_started_despite(t, 4, 10s)) << t.why();
  EXPECT_EQ(log.count("start sent again"), 3u);
  EXPECT_GE(log.count("pre-operational again"), 1u);
  EXPECT_TRUE(t.line.run_until(VirtualLine::all_in(DeviceState::operational), 2s).has_value()) << t.why();
}

// The wall clock stepped back an hour (NTP) after the start: a device put
// back to pre-operational a few seconds later is still news, its heartbeat
// stamps earlier than the start notwithstanding.
TEST(BusManagerLine, Cia301_PreOperationalAfterAWallClockStepIsNews) {
  const LogCapture log;
  OneMultiturn t;
  ASSERT_TRUE(t.operational());
  t.line.run_for(3s);  // every start made
  t.line.step_wall_clock(-3600s);
  t.line.run_for(2s);
  ASSERT_TRUE(t.other.send(nmt(0x80, 20)));
  ASSERT_TRUE(t.line.run_until([&](const BusStatus&) { return log.count("pre-operational again") == 1; }, 2s));
  ASSERT_TRUE(t.line.run_until(
      [&](const BusStatus&) { return t.dev.nmt_state() == canopen::NmtState::operational; }, 3s));
}

// A device power-cycled while operational (boot-up, CiA 301 §7.2.8.3.1):
// configured again and operational; the way back is bounded.
TEST(BusManagerLine, Cia301_7_2_8_3_1_BootUpWhileOperationalReconfigured) {
  OneMultiturn t;
  ASSERT_TRUE(t.operational());
  ASSERT_FALSE(t.dev.power_cycle(t.line.now()));
  t.line.run_for(5ms);
  const auto back = t.line.run_until(VirtualLine::is("mt-a", DeviceState::operational), 5s);
  ASSERT_TRUE(back);
  EXPECT_LT(*back, 2s);
  t.line.run_for(10ms);  // the NMT start on its way
  EXPECT_EQ(t.dev.nmt_state(), canopen::NmtState::operational);
}

// CiA 305 Fastscan at scale: 32 factory-fresh multiturns, all at FFh, each
// found and given its configured node-ID, all operational.
TEST(BusManagerLine, Cia305_ThirtyTwoFactoryFreshAtFFh) {
  std::string devices;
  for (int i = 0; i < 32; ++i)
    devices += device_toml(("mt-" + std::to_string(i)).c_str(), "MC1-2800", static_cast<std::uint32_t>(5000 + i), 20 + i);
  VirtualLine line(kBus, devices);
  for (int i = 0; i < 32; ++i) line.add_device("MC1-2800", static_cast<std::uint32_t>(5000 + i), 0xFF);
  line.start();
  const auto took = line.run_until(VirtualLine::all_in(DeviceState::operational), 30s);
  ASSERT_TRUE(took);
  std::cout << "FIGURE 32 factory-fresh multiturns at FFh: all operational after " << took->count()
            << " ms of bus time (500 us per frame)\n";
  for (int i = 0; i < 32; ++i) EXPECT_EQ(line.device("mt-" + std::to_string(i))->node_id, 20 + i);
}

// A stranger (a serial the configuration does not name) at a free node-ID:
// shown as unknown, never configured (no SDO download reaches it).
TEST(BusManagerLine, UnknownSerialShownNeverConfigured) {
  VirtualLine line(kBus, device_toml("mt-a", "MC1-2800", 2001, 20));
  line.add_device("MC1-2800", 2001, 20);
  line.add_device("MC1-2800", 9999, 30);
  line.start();
  ASSERT_TRUE(line.run_until(VirtualLine::is("mt-a", DeviceState::operational), 5s));
  line.run_for(2s);
  const BusStatus st = line.status();
  const bool listed = std::any_of(st.devices.begin(), st.devices.end(), [](const DeviceStatus& d) {
    return d.identity.serial == 9999 && d.node_id == 30;
  });
  EXPECT_TRUE(listed) << "the stranger is in the status";
  EXPECT_EQ(sdo_downloads(line.bus(), 30), 0u) << "nothing written to the stranger";
}

// docs/configuration.md on_config_drift = "restore": another client's
// write of a configured object (0x1017, CiA 301 §7.5.2.31) is put back.
TEST(BusManagerLine, Cia301_DriftOfHeartbeatRestored) {
  OneMultiturn t;
  ASSERT_TRUE(t.operational());
  const std::size_t mark = t.line.bus().log().size();
  ASSERT_TRUE(t.other.send(sdo_write_u16(20, 0x1017, 0, 200)));
  ASSERT_TRUE(t.heartbeat_becomes(100, 3s));
  EXPECT_EQ(heartbeat_writes(t.line.bus(), 20, mark), 2u) << "the client's write, then the gateway's";
  ASSERT_TRUE(t.line.run_until(VirtualLine::is("mt-a", DeviceState::operational), 3s));
  EXPECT_TRUE(t.line.device("mt-a")->drift.empty()) << "restored: the record closed";
}

// The fighting writer: a client that sets 0x1017 to its own value every
// 2 s for a minute meets at most 3 restores; then the object is contested
// (status says so) and nothing more is written until an operator
// acknowledges it.
TEST(BusManagerLine, DriftFromAFightingWriterContestedAfterThreeRestores) {
  OneMultiturn t;
  ASSERT_TRUE(t.operational());
  const std::size_t mark = t.line.bus().log().size();
  unsigned writes = 0;
  for (; writes < 30; ++writes) {
    ASSERT_TRUE(t.other.send(sdo_write_u16(20, 0x1017, 0, 200)));
    t.line.run_for(2s);
  }
  const std::size_t gateway_writes = heartbeat_writes(t.line.bus(), 20, mark) - writes;
  EXPECT_LE(gateway_writes, 3u) << "restores of a fought-over object";
  EXPECT_GE(gateway_writes, 1u) << "the first drift is restored";
  EXPECT_EQ(contested_count(*t.line.device("mt-a")), 1u);
  EXPECT_EQ(t.dev.object_dictionary()->get_u16(0x1017, 0), std::optional<std::uint16_t>(200)) << "left to the writer";
  t.line.manager().acknowledge_contested("mt-a", "unit test");
  EXPECT_TRUE(t.heartbeat_becomes(100, 5s)) << "acknowledged: restored again";
}

// An EMCY storm (CiA 301 §7.2.7) faster than the control thread reads:
// the frames its full receive queue lost are logged with their count (the
// status's rx_overflow_drops), so the log's EMCY count plus that covers
// every EMCY sent; the device stays operational.
TEST(BusManagerLine, Cia301_7_2_7_EmcyStormPastTheReceiveQueueIsDeclared) {
  LogCapture logs;
  VirtualLine line(kBus, device_toml("mt-a", "MC1-2800", 2001, 20), {""}, 64);
  line.add_device("MC1-2800", 2001, 20);
  auto& storm = line.bus().attach();
  line.start();
  ASSERT_TRUE(line.run_until(VirtualLine::all_in(DeviceState::operational), 5s));
  constexpr unsigned kSent = 500;
  for (unsigned i = 0; i < kSent; ++i) {
    can::Frame f;
    f.id = 0x080U + 20;
    f.len = 8;
    f.data = {static_cast<std::uint8_t>(i), 0x10, 0x01, 0, 0, 0, 0, 0};
    ASSERT_TRUE(storm.send(f));
  }
  line.run_for(12s);  // the EMCY log budget's window (10 s) ends: its summary
  const std::uint64_t drops = line.status().rx_overflow_drops;
  EXPECT_GE(drops, kSent - 64);
  EXPECT_EQ(logs.count("dropped " + std::to_string(drops) + " frames at the control thread's full receive queue"), 1u);
  std::size_t logged = 0;
  std::uint64_t summed = 0;
  for (const auto& l : logs.lines()) {
    if (const auto at = l.find("): "); at != std::string::npos && l.find("more EMCY not logged") != std::string::npos)
      summed += std::stoull(l.substr(at + 3));
    else if (l.find("device mt-a (node 20): ") != std::string::npos)
      ++logged;
  }
  EXPECT_GE(logged + summed + drops, kSent) << logged << " logged, " << summed << " summed up";
  EXPECT_EQ(line.device("mt-a")->state, DeviceState::operational);
}

// SIGHUP (docs/operations.md "Reload"): a changed heartbeat period is
// written to the device without closing the bus.
TEST(BusManagerLine, ReloadWritesTheChangedSetting) {
  OneMultiturn t;
  ASSERT_TRUE(t.operational());
  t.line.manager().reload(t.line.load(kBus, device_toml("mt-a", "MC1-2800", 2001, 20, 250)));
  ASSERT_TRUE(t.heartbeat_becomes(250, 3s));
  ASSERT_TRUE(t.line.run_until(VirtualLine::all_in(DeviceState::operational), 3s));
}

}  // namespace
}  // namespace cobridge::bus::test
