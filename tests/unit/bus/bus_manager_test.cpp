// The bus controller's decisions on a virtual bus (VirtualLine: BusManager
// stepped, the simulator's encoders, a fake clock): commissioning, plans,
// supervision and their faults, each in milliseconds of CPU and no sleep.
// The end-to-end tests in tests/vcan/daemon run the same decisions on
// SocketCAN in a VM, with the real daemon and timing bounds.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "canopen/cob_id.hpp"
#include "unit/bus/virtual_line.hpp"

namespace cobridge::gateway::test {
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
  VirtualLine line(kBus, device_toml("mt-a", "MC1-2800", 2001, 20));
  sim::SimDevice& dev = line.add_device("MC1-2800", 2001, 20);
  line.start();
  ASSERT_TRUE(line.run_until(VirtualLine::all_in(DeviceState::operational), 5s));
  dev.set_silent(true);
  const auto lost = line.run_until(VirtualLine::is("mt-a", DeviceState::offline), 2s);
  ASSERT_TRUE(lost) << "still " << to_string(line.device("mt-a")->state);
  EXPECT_LE(*lost, 500ms) << "consumer time of a 100 ms heartbeat";
  EXPECT_FALSE(line.device("mt-a")->online);
  dev.set_silent(false);
  ASSERT_TRUE(line.run_until(VirtualLine::is("mt-a", DeviceState::operational), 3s));
  const std::size_t mark = line.bus().log().size();
  line.run_for(500ms);
  EXPECT_GE(tpdo1_frames(line.bus(), 20, mark), 3u);
}

// A device that reboots in the middle of its configuration (boot-up mid
// plan, E§8.2): the plan that was running is dropped, the device is
// configured again from the start and ends operational.
TEST(BusManagerLine, E8_2_PowerCycleMidPlanEndsConfigured) {
  VirtualLine line(kBus, device_toml("mt-a", "MC1-2800", 2001, 20));
  sim::SimDevice& dev = line.add_device("MC1-2800", 2001, 20);
  line.start();
  ASSERT_TRUE(line.run_until(VirtualLine::is("mt-a", DeviceState::configuring), 2s));
  dev.reboot_on_sdo(3);  // the plan's third request from now
  ASSERT_TRUE(line.run_until(VirtualLine::all_in(DeviceState::operational), 10s))
      << to_string(line.device("mt-a")->state) << ": " << line.device("mt-a")->last_error;
  line.run_for(10ms);  // the NMT start on its way
  EXPECT_EQ(dev.nmt_state(), canopen::NmtState::operational);
  EXPECT_GE(line.device("mt-a")->boot_ups, 1u) << "the reboot was seen";
}

// CiA 301 §7.2.4.3.17 SDO abort during the plan: the run fails, is tried
// again after its delay, and the device ends operational.
TEST(BusManagerLine, Cia301_7_2_4_3_17_SdoAbortRetriedThenOperational) {
  VirtualLine line(kBus, device_toml("mt-a", "MC1-2800", 2001, 20));
  sim::SimDevice& dev = line.add_device("MC1-2800", 2001, 20);
  dev.abort_sdo(0x1017, 0x08000020);  // data cannot be stored
  line.start();
  ASSERT_TRUE(line.run_until(VirtualLine::all_in(DeviceState::operational), 10s))
      << to_string(line.device("mt-a")->state) << ": " << line.device("mt-a")->last_error;
  ASSERT_NE(dev.object_dictionary(), nullptr);
  EXPECT_EQ(dev.object_dictionary()->get_u16(0x1017, 0), std::optional<std::uint16_t>(100));
}

// A device power-cycled while operational (boot-up, CiA 301 §7.2.8.3.1):
// configured again and operational; the way back is bounded.
TEST(BusManagerLine, Cia301_7_2_8_3_1_BootUpWhileOperationalReconfigured) {
  VirtualLine line(kBus, device_toml("mt-a", "MC1-2800", 2001, 20));
  sim::SimDevice& dev = line.add_device("MC1-2800", 2001, 20);
  line.start();
  ASSERT_TRUE(line.run_until(VirtualLine::all_in(DeviceState::operational), 5s));
  ASSERT_FALSE(dev.power_cycle(line.now()));
  line.run_for(5ms);
  const auto back = line.run_until(VirtualLine::is("mt-a", DeviceState::operational), 5s);
  ASSERT_TRUE(back);
  EXPECT_LT(*back, 2s);
  line.run_for(10ms);  // the NMT start on its way
  EXPECT_EQ(dev.nmt_state(), canopen::NmtState::operational);
}

}  // namespace
}  // namespace cobridge::gateway::test
