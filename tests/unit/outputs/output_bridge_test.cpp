// OutputBridge: the decode plan the hot path gets for each family, from the
// shipped EDS files (signedness per object) and the configuration.
#include "outputs/output_bridge.hpp"

#include "unit/device/source_paths.hpp"  // locates config/devices

#include <gtest/gtest.h>

using namespace cobridge;
using namespace cobridge::outputs;

namespace {

struct Fixture {
  config::Config cfg;
  device::DeviceCatalog catalog;
  pipeline::DeviceTable table;
  Fixture() {
    (void)catalog.load_directory(device::test::shipped_devices_dir());
    config::Bus bus;
    bus.name = "line1";
    bus.interface = "vcan0";
    cfg.buses.push_back(bus);
    config::Device d;
    d.name = "lift";
    d.bus = "line1";
    d.serial = 1001;
    config::TpdoSettings t;
    t.transmission = 254;
    t.event_timer_ms = 10;
    d.tpdo1 = t;
    config::TpdoSettings t2;
    t2.transmission = 1;
    d.tpdo2 = t2;
    config::Scaling sc;
    sc.units_per_rev = 3600;
    d.scaling = sc;
    cfg.devices.push_back(d);
  }
  bus::DeviceStatus status(std::string name, std::uint32_t vendor, std::uint32_t product, std::uint8_t node) {
    bus::DeviceStatus s;
    s.name = std::move(name);
    s.node_id = node;
    s.identity = canopen::LssAddress{vendor, product, 0x00010003, 1001};
    return s;
  }
};

}  // namespace

// J§1.7.2 default mapping: 0x6020/1 INTEGER32 and 0x6030/1 INTEGER16 are signed.
TEST(OutputBridge, J_1_7_2_RotaryPlanSignedAndScaledFromConfig) {
  Fixture f;
  SharedConfig shared(f.cfg);
  OutputBridge bridge(shared, 0, f.catalog, f.table, nullptr, nullptr, nullptr);
  Error err;
  const auto plan = bridge.make_plan(f.status("lift", 0x182, 0x0BE0, 10), {0x60200120, 0x60300110}, {0x60200120}, &err);
  ASSERT_TRUE(plan.active) << err.to_string();
  EXPECT_EQ(plan.tpdo[0].count, 2);
  EXPECT_TRUE(plan.tpdo[0].fields[0].is_signed);
  EXPECT_TRUE(plan.tpdo[0].fields[1].is_signed);
  EXPECT_EQ(plan.tpdo[0].frame_length, 6);
  EXPECT_DOUBLE_EQ(plan.eng_scale, 0.1) << "360 deg / 3600 units per revolution";
  EXPECT_FALSE(plan.synchronous[0]);
  EXPECT_TRUE(plan.synchronous[1]) << "TPDO2 type 1 is sent on SYNC";
  EXPECT_EQ(plan.max_age_ms, 50u) << "three 10 ms event-timer periods + 20 ms";
  EXPECT_EQ(bridge.device_index(f.status("lift", 0x182, 0x0BE0, 10)), std::optional<std::uint16_t>(0));
}

// F§7.5: ifm 0x6004 is UNSIGNED32; F§7.4: bits 30/31 are limit-switch flags.
TEST(OutputBridge, F_7_5_IfmPositionUnsignedWithLimitSwitchMask) {
  Fixture f;
  SharedConfig shared(f.cfg);
  OutputBridge bridge(shared, 0, f.catalog, f.table, nullptr, nullptr, nullptr);
  Error err;
  const auto plan = bridge.make_plan(f.status("ifm-x", 0x0069666D, 0x4341, 32), {0x60040020}, {}, &err);
  ASSERT_TRUE(plan.active) << err.to_string();
  EXPECT_FALSE(plan.tpdo[0].fields[0].is_signed);
  EXPECT_EQ(plan.position_mask, 0x3FFFFFFFu);
  EXPECT_DOUBLE_EQ(plan.eng_scale, 1.0) << "F§7.5 gives the resolution only on the label: counts, not degrees";
  EXPECT_FALSE(bridge.device_index(f.status("ifm-x", 0x0069666D, 0x4341, 32)).has_value())
      << "not in the configuration, and no pool for such devices: not published";
  DeviceIndexPool pool;
  OutputBridge pooled(shared, 0, f.catalog, f.table, nullptr, nullptr, nullptr, &pool);
  EXPECT_EQ(pooled.device_index(f.status("ifm-x", 0x0069666D, 0x4341, 32)), DeviceIndexPool::kFirst);
}

// E§4.1: the multiturn default mapping names 0x6020/1 (an alias of INTEGER32 0x6004).
TEST(OutputBridge, E_4_1_MultiturnAliasDecodesSigned) {
  Fixture f;
  SharedConfig shared(f.cfg);
  OutputBridge bridge(shared, 0, f.catalog, f.table, nullptr, nullptr, nullptr);
  Error err;
  const auto plan = bridge.make_plan(f.status("mt", 0x182, 0x0BB8, 12), {0x60200120, 0x60300110}, {}, &err);
  ASSERT_TRUE(plan.active) << err.to_string();
  EXPECT_TRUE(plan.tpdo[0].fields[0].is_signed);
  EXPECT_EQ(plan.tpdo[0].fields[0].signal, pipeline::Signal::position);
}

TEST(OutputBridge, UndecodableMappingIsRefusedWithDeviceName) {
  Fixture f;
  SharedConfig shared(f.cfg);
  OutputBridge bridge(shared, 0, f.catalog, f.table, nullptr, nullptr, nullptr);
  Error err;
  const auto plan = bridge.make_plan(f.status("lift", 0x182, 0x0BE0, 10), {0x60200120, 0x60200120, 0x60300110}, {}, &err);
  EXPECT_FALSE(plan.active);
  EXPECT_NE(err.to_string().find("lift"), std::string::npos) << err.to_string();
}

// Configured devices become active plans in the bus's table.
TEST(OutputBridge, ConfiguredDeviceIsPublishedToTheHotPath) {
  Fixture f;
  SharedConfig shared(f.cfg);
  OutputBridge bridge(shared, 0, f.catalog, f.table, nullptr, nullptr, nullptr);
  bridge.on_device_configured(f.status("lift", 0x182, 0x0BE0, 10), {0x60200120, 0x60300110}, {});
  pipeline::DeviceTable::Plans plans;
  std::uint32_t gen = 0;
  f.table.snapshot(plans, gen);
  EXPECT_TRUE(plans[10].active);
  EXPECT_EQ(plans[10].node_id, 10);
  EXPECT_GT(gen, 0u);
}

namespace cobridge::outputs {
namespace {

// A SIGHUP reload reaches the output side too. A new event
// timer changes the staleness limit of the plan made after the reload.
TEST(OutputBridge, ReloadedSettingsReachTheNextPlan) {
  Fixture f;
  SharedConfig shared(f.cfg);
  OutputBridge bridge(shared, 0, f.catalog, f.table, nullptr, nullptr, nullptr);
  const auto st = f.status("lift", 0x182, 0x0BE0, 10);
  EXPECT_EQ(bridge.make_plan(st, {0x60200120}, {}, nullptr).max_age_ms, 50u);
  config::Config next = f.cfg;
  next.devices[0].tpdo1->event_timer_ms = 100;
  shared.set(next);
  EXPECT_EQ(bridge.make_plan(st, {0x60200120}, {}, nullptr).max_age_ms, 320u) << "3 x 100 ms + 20 ms";
}

}  // namespace
}  // namespace cobridge::outputs

namespace cobridge::outputs {
namespace {

// docs/plugins.md "Bus health" (plugin.h ABI 5 cobridge_bus_info): the
// controller's ISO 11898-1 state, where the figures came from, and
// counters only when the driver reported them.
TEST(OutputBridge, BusHealthBecomesTheAbi5BusInfo) {
  bus::BusHealth h;
  h.open = true;
  h.error_frames = 7;
  h.controller.state = can::ControllerState::error_passive;
  h.controller.source = can::HealthSource::netlink;
  h.controller.driver = can::DriverReport::state;
  h.controller.counters_known = true;
  h.controller.tx_errors = 300;
  h.controller.rx_errors = 2;
  h.controller.restarts = 4;
  h.controller.since_ns = 99;
  cobridge_bus_info info = to_bus_info(h, 3);
  EXPECT_EQ(info.struct_size, sizeof info);
  EXPECT_EQ(info.bus_index, 3);
  EXPECT_EQ(info.open, 1);
  EXPECT_EQ(info.state, COBRIDGE_CONTROLLER_ERROR_PASSIVE);
  EXPECT_EQ(info.source, COBRIDGE_SOURCE_NETLINK);
  EXPECT_EQ(info.driver_reports_state, 1);
  EXPECT_EQ(info.counters_known, 1);
  EXPECT_EQ(info.tx_errors, 300);
  EXPECT_EQ(info.rx_errors, 2);
  EXPECT_EQ(info.restarts, 4u);
  EXPECT_EQ(info.error_frames, 7u);
  EXPECT_EQ(info.since_ns, 99u);
  // vcan: no state from the driver, counters never reported.
  bus::BusHealth v;
  v.controller.driver = can::DriverReport::no_state;
  v.controller.tx_errors = 5;  // stale, not reported: must not show
  info = to_bus_info(v, 0);
  EXPECT_EQ(info.state, COBRIDGE_CONTROLLER_UNKNOWN);
  EXPECT_EQ(info.source, COBRIDGE_SOURCE_NONE);
  EXPECT_EQ(info.driver_reports_state, 0);
  EXPECT_EQ(info.counters_known, 0);
  EXPECT_EQ(info.tx_errors, 0);
  v.controller.driver = can::DriverReport::failed;
  EXPECT_EQ(to_bus_info(v, 0).driver_reports_state, 2) << "not known";
}

}  // namespace
}  // namespace cobridge::outputs
