// Multiturn condition monitoring: E§4.3 (0x2002, 0x2003, 0x2300..0x236B), E§5.8,
// E§9.1, E§10.1 (EMCY and 0x1002 bits), E§4.3, E§5.8.
#include "encoder/condition_monitor.hpp"

#include "encoder/abort_code.hpp"

#include <gtest/gtest.h>

namespace cobridge::sim {
namespace {

// E§4.3 0x2310: boot cycles since maintenance and total; 0x2300/1 clears only the former.
TEST(ConditionMonitor, E_4_3_BootCycleCounter) {
  ConditionMonitor m;
  m.power_up();
  m.power_up();
  EXPECT_EQ(m.history().boot_total, 2U);
  EXPECT_EQ(m.history().boot_since_maintenance, 2U);
  EXPECT_EQ(m.reset_command(1), abort_code::kOk);
  m.power_up();
  EXPECT_EQ(m.history().boot_since_maintenance, 1U);
  EXPECT_EQ(m.history().boot_total, 3U);
}

// E§4.3 0x2320 / 0x232A: operating time in 0.1 h ticks; time_scale accelerates it.
TEST(ConditionMonitor, E_4_3_OperatingTimeTenthHours) {
  ConditionMonitor m;
  m.power_up();
  m.update(359.0, 0.0, 0);
  EXPECT_EQ(m.time_since_power_on(), 0U);
  m.update(1.0, 0.0, 0);
  EXPECT_EQ(m.time_since_power_on(), 1U);
  EXPECT_EQ(m.history().time_since_maintenance, 1U);
  EXPECT_EQ(m.history().time_total, 1U);
  m.time_scale = 3600.0;  // one second = one hour
  m.update(1.0, 0.0, 0);
  EXPECT_EQ(m.time_since_power_on(), 11U);
  EXPECT_EQ(m.history().time_total, 11U);
}

// E§5.8: a power cycle sets only the "power-on" values to 0; the history stays.
TEST(ConditionMonitor, E_5_8_PowerCycleClearsPowerOnOnly) {
  ConditionMonitor m;
  m.power_up();
  m.time_scale = 3600.0;
  m.set_temperature(400);
  m.update(1.0, 0.0, 0);
  m.update(0.0, 3.0, 0);
  EXPECT_EQ(m.odometer_since_power_on(), 3U);
  EXPECT_EQ(m.temperature_tracker().power_on.max, 400);
  m.power_up();
  EXPECT_EQ(m.time_since_power_on(), 0U);
  EXPECT_EQ(m.odometer_since_power_on(), 0U);
  EXPECT_FALSE(m.temperature_tracker().power_on.has_max);
  EXPECT_EQ(m.temperature_tracker().power_on.max, 0);
  EXPECT_EQ(m.temperature_tracker().lifetime.max, 400);
  EXPECT_EQ(m.history().time_total, 10U);
  EXPECT_EQ(m.history().odometer_total, 3U);
  // Non-volatile round trip: restore keeps the history, not the power-on values.
  ConditionMonitor n;
  n.restore(m.history());
  EXPECT_EQ(n.history().boot_total, 2U);
  EXPECT_EQ(n.temperature_tracker().lifetime.max, 400);
}

// E§4.3 0x2350 / 0x2360: min/max over four windows; 0x2300/3..6 reset the
// "since reset" min/max to 0, re-seeded by the next sample (E§4.3, E§5.8).
TEST(ConditionMonitor, E_4_3_TemperatureVoltageTrackers) {
  ConditionMonitor m;
  m.power_up();
  for (const int t : {300, 500, 200}) {
    m.set_temperature(static_cast<std::int16_t>(t));
    m.update(0.001, 0.0, 0);
  }
  m.set_voltage(230);
  m.update(0.001, 0.0, 0);
  const auto& temp = m.temperature_tracker();
  EXPECT_EQ(temp.power_on.min, 200);
  EXPECT_EQ(temp.power_on.max, 500);
  EXPECT_EQ(temp.lifetime.min, 200);
  EXPECT_EQ(m.voltage_tracker().since_reset.min, 230);
  EXPECT_EQ(m.reset_command(3), abort_code::kOk);
  EXPECT_EQ(temp.since_reset.min, 0);  // "reset to zero"
  EXPECT_EQ(temp.since_reset.max, 500);
  EXPECT_EQ(temp.lifetime.min, 200);
  m.set_temperature(350);
  m.update(0.001, 0.0, 0);
  EXPECT_EQ(temp.since_reset.min, 350);
  EXPECT_EQ(temp.since_reset.max, 500);
  EXPECT_EQ(m.reset_command(4), abort_code::kOk);
  EXPECT_EQ(temp.since_reset.max, 0);
  EXPECT_EQ(m.reset_command(6), abort_code::kOk);
  EXPECT_EQ(m.voltage_tracker().since_reset.max, 0);
  EXPECT_EQ(m.voltage_tracker().since_reset.min, 230);
  EXPECT_EQ(m.reset_command(5), abort_code::kOk);
  EXPECT_EQ(m.voltage_tracker().since_reset.min, 0);
  EXPECT_EQ(m.reset_command(7), abort_code::kSubIndexDoesNotExist);
  EXPECT_EQ(m.reset_command(0), abort_code::kSubIndexDoesNotExist);
}

// E§4.3 0x233A / 0x2330: lot size counts the selected CAM1/CAM2 edge; 0x2300/2 resets it.
TEST(ConditionMonitor, E_4_3_LotSizeOnCamEdges) {
  ConditionMonitor m;
  m.power_up();
  m.update(0.001, 0.0, 0);
  m.lot_size_config = 1;  // CAM1 rising: 3 rises, 2 falls
  for (const int c : {1, 0, 1, 0, 1}) m.update(0.001, 0.0, static_cast<std::uint8_t>(c));
  EXPECT_EQ(m.lot_since_power_on(), 3U);
  m.update(0.001, 0.0, 0);
  m.lot_size_config = 2;  // CAM1 falling: 2 falls, 3 rises
  for (const int c : {1, 0, 1, 0, 1}) m.update(0.001, 0.0, static_cast<std::uint8_t>(c));
  EXPECT_EQ(m.lot_since_power_on(), 5U);
  m.lot_size_config = 4;  // CAM2 falling; CAM1 toggling must not count
  for (const int c : {2, 1, 3, 0, 2}) m.update(0.001, 0.0, static_cast<std::uint8_t>(c));
  EXPECT_EQ(m.lot_since_power_on(), 7U);
  m.lot_size_config = 3;  // CAM2 rising
  for (const int c : {0, 2, 3, 1, 2}) m.update(0.001, 0.0, static_cast<std::uint8_t>(c));
  EXPECT_EQ(m.lot_since_power_on(), 9U);
  m.lot_size_config = 0;  // off
  for (const int c : {0, 3, 0, 3}) m.update(0.001, 0.0, static_cast<std::uint8_t>(c));
  EXPECT_EQ(m.lot_since_power_on(), 9U);
  EXPECT_EQ(m.history().lot_since_reset, 9U);
  EXPECT_EQ(m.reset_command(2), abort_code::kOk);
  EXPECT_EQ(m.history().lot_since_reset, 0U);
  EXPECT_EQ(m.history().lot_since_maintenance, 9U);
  EXPECT_EQ(m.history().lot_total, 9U);
}

// E§4.3 0x2340 / 0x234A: odometer accumulates absolute movement in turns.
TEST(ConditionMonitor, E_4_3_OdometerAbsoluteTurns) {
  ConditionMonitor m;
  m.power_up();
  for (const double t : {0.0, 0.6, 1.2, 0.2}) m.update(0.001, t, 0);
  EXPECT_EQ(m.odometer_since_power_on(), 2U);  // 0.6 + 0.6 + 1.0 = 2.2
  m.update(0.001, 0.0, 0);
  EXPECT_EQ(m.odometer_since_power_on(), 2U);  // 2.4
  m.update(0.001, 0.7, 0);
  EXPECT_EQ(m.odometer_since_power_on(), 3U);  // 3.1
  EXPECT_EQ(m.history().odometer_since_maintenance, 3U);
  EXPECT_EQ(m.reset_command(1), abort_code::kOk);
  EXPECT_EQ(m.history().odometer_since_maintenance, 0U);
  EXPECT_EQ(m.history().odometer_total, 3U);
}

// E§10.1 bits 2..9 and E§9.1 0x4210/0x3100: user thresholds set bits only,
// factory thresholds set bits and raise the warning EMCY (E§4.3, E§5.8).
TEST(ConditionMonitor, E_10_1_ThresholdBitsAndEvents) {
  ConditionMonitor m;
  m.power_up();
  m.set_temperature(900);  // above user max 85.0, below factory max 105.0
  auto ev = m.update(0.001, 0.0, 0);
  EXPECT_EQ(ev.count, 0);
  EXPECT_EQ(m.status_bits(), kStatusTempOverUser);
  m.set_temperature(1100);
  ev = m.update(0.001, 0.0, 0);
  ASSERT_EQ(ev.count, 1);
  EXPECT_EQ(ev.items[0].code, 0x4210);
  EXPECT_EQ(ev.items[0].byte2, 1);
  EXPECT_EQ(ev.items[0].byte3, 1);
  EXPECT_TRUE(ev.items[0].active);
  EXPECT_EQ(m.status_bits(), kStatusTempOverUser | kStatusTempOverFactory);
  EXPECT_EQ(m.update(0.001, 0.0, 0).count, 0);  // no repeat while it persists
  m.set_temperature(300);
  ev = m.update(0.001, 0.0, 0);
  ASSERT_EQ(ev.count, 1);
  EXPECT_FALSE(ev.items[0].active);
  EXPECT_EQ(m.status_bits(), 0U);
  m.set_voltage(70);  // below user min 10.0 V and factory min 8.0 V
  ev = m.update(0.001, 0.0, 0);
  ASSERT_EQ(ev.count, 1);
  EXPECT_EQ(ev.items[0].code, 0x3100);
  EXPECT_EQ(ev.items[0].byte3, 2);
  EXPECT_EQ(m.status_bits(), kStatusVoltUnderUser | kStatusVoltUnderFactory);
  m.thresholds.volt_factory_min = 60;  // 0x236B is factory-set; the test moves it anyway
  ev = m.update(0.001, 0.0, 0);
  EXPECT_EQ(m.status_bits(), kStatusVoltUnderUser);
}

// E§4.3 0x230A, E§9.1 0x5000/0/1 (Info), E§10.1 bit 25, E§10.3 0x6505 bit 3.
TEST(ConditionMonitor, E_4_3_MaintenanceRequired) {
  ConditionMonitor m;
  m.power_up();
  m.maintenance_hours = 2;
  m.time_scale = 3600.0;
  auto ev = m.update(1.0, 0.0, 0);  // 1 h
  EXPECT_EQ(ev.count, 0);
  ev = m.update(1.0, 0.0, 0);  // 2 h
  ASSERT_EQ(ev.count, 1);
  EXPECT_EQ(ev.items[0].code, 0x5000);
  EXPECT_EQ(ev.items[0].byte2, 0);
  EXPECT_EQ(ev.items[0].byte3, 1);
  EXPECT_EQ(ev.items[0].level, ConditionEvent::Level::info);
  EXPECT_EQ(m.status_bits() & kStatusMaintenance, kStatusMaintenance);
  EXPECT_EQ(m.warning_bits(), kWarningMaintenance);
  EXPECT_EQ(m.reset_command(1), abort_code::kOk);
  ev = m.update(0.001, 0.0, 0);
  ASSERT_EQ(ev.count, 1);
  EXPECT_FALSE(ev.items[0].active);
  EXPECT_EQ(m.warning_bits(), 0);
  m.maintenance_hours = 0;  // 0 = deactivated
  m.update(100.0, 0.0, 0);
  EXPECT_EQ(m.status_bits() & kStatusMaintenance, 0U);
}

}  // namespace
}  // namespace cobridge::sim
