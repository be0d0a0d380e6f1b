// Position pipeline per family: J (Novotechnik rotary), E (multiturn), F (ifm).
#include "encoder/position_pipeline.hpp"

#include "encoder/abort_code.hpp"

#include <gtest/gtest.h>

namespace cobridge::sim {
namespace {

using abort_code::kOk;
using abort_code::kValueExceeded;
using abort_code::kWrongState;

PositionPipeline make(FamilyId f) { return PositionPipeline(PositionSettings::defaults(f)); }

// Feed `turns_per_s` for `cycles` 1 ms cycles starting at t0; returns the last sample.
PositionSample run(PositionPipeline& p, double turns_per_s, int cycles, double t0 = 0.0, double start = 0.0) {
  PositionSample s;
  for (int i = 0; i <= cycles; ++i) {
    const double t = t0 + i * 0.001;
    s = p.update(start + turns_per_s * (t - t0), t);
  }
  return s;
}

// ---------------- Rotary (J) ----------------

// J§1.2.3: 14-bit single turn; J§1.3.2 0x6501 = 0x6001 = 0x6002 = 0x4000.
TEST(PositionPipelineRotary, J_1_2_3_FourteenBitSingleTurnWraps) {
  auto p = make(FamilyId::novotechnik_rotary);
  EXPECT_EQ(p.settings().units_per_rev, 0x4000U);
  EXPECT_EQ(p.update(0.25, 0.0).position, 0x1000U);
  EXPECT_EQ(p.update(1.25, 0.001).position, 0x1000U);
  EXPECT_EQ(p.update(-0.25, 0.002).position, 0x3000U);
  EXPECT_EQ(p.update(0.999999, 0.003).position, 0x3FFFU);
}

// J§1.4.1 bit 0 counting direction; ccw reads total-1-pos; speed follows.
TEST(PositionPipelineRotary, J_1_4_1_CounterClockwiseMirrorsPositionAndSpeed) {
  auto p = make(FamilyId::novotechnik_rotary);
  p.settings().operating_parameter = 0x0001;
  EXPECT_EQ(p.update(0.25, 0.0).position, 0x3FFFU - 0x1000U);
  const auto s = run(p, 0.5, 10, 0.001, 0.25);
  EXPECT_EQ(s.speed, -1800);
}

// J§1.4.1 bit 2 = 1 scaling on (E§5.3 prints the opposite); J§1.4.2 0x6001 scaling.
TEST(PositionPipelineRotary, J_1_4_1_ScalingBitOneIsOn) {
  auto p = make(FamilyId::novotechnik_rotary);
  p.settings().units_per_rev = 0x1000;
  p.settings().total_range = 0x1000;
  EXPECT_FALSE(p.scaling_active());
  EXPECT_EQ(p.update(0.5, 0.0).position, 0x2000U);  // off: physical units
  p.settings().operating_parameter = 0x0004;
  EXPECT_TRUE(p.scaling_active());
  EXPECT_EQ(p.update(0.5, 0.001).position, 0x800U);
  EXPECT_EQ(p.update(1.75, 0.002).position, 0xC00U);  // modulo total range
}

// J§1.4.2: 0x6001 writable only with scaling on; only reductions (J§1.4.2, E§5.4).
TEST(PositionPipelineRotary, J_1_4_2_ScalingWriteRules) {
  const auto s = PositionSettings::defaults(FamilyId::novotechnik_rotary);
  EXPECT_EQ(check_scaling_write_allowed(s, 0x0000), kWrongState);
  EXPECT_EQ(check_scaling_write_allowed(s, 0x0004), kOk);
  EXPECT_EQ(check_units_per_rev(s, 0x4001), kValueExceeded);
  EXPECT_EQ(check_units_per_rev(s, 0), kValueExceeded);
  EXPECT_EQ(check_units_per_rev(s, 0x4000), kOk);
  EXPECT_EQ(check_total_range(s, 0x4001), kValueExceeded);
  EXPECT_EQ(coupled_total_range(s, 0x1000), 0x1000U);  // 0x6502 = 1
  EXPECT_EQ(coupled_units_per_rev(s, 0x800), 0x800U);
}

// J§1.4.1 bits 14..12: moving average over 2^n values for position and speed.
TEST(PositionPipelineRotary, J_1_4_1_MovingAverageDelaysPosition) {
  auto plain = make(FamilyId::novotechnik_rotary);
  auto avg = make(FamilyId::novotechnik_rotary);
  avg.settings().operating_parameter = 2U << 12;  // 4 values
  EXPECT_EQ(avg.filter_exponent(), 2U);
  const auto a = run(plain, 1.0, 10);
  const auto b = run(avg, 1.0, 10);
  EXPECT_EQ(a.position, 163U);  // floor(0.010 * 16384)
  EXPECT_EQ(b.position, 139U);  // mean of 0.007..0.010 = 0.0085 turns
  EXPECT_EQ(a.speed, 3600);     // 1 turn/s in 0.1 deg/s
  EXPECT_EQ(b.speed, 3600);
}

// J§1.3.2 0x6030: speed 0.1 deg/s, INTEGER16 saturating at +-32767.
TEST(PositionPipelineRotary, J1_3_2_SpeedTenthDegreePerSecondSaturates) {
  auto p = make(FamilyId::novotechnik_rotary);
  EXPECT_EQ(run(p, 0.5, 5).speed, 1800);
  auto q = make(FamilyId::novotechnik_rotary);
  const auto s = run(q, -10.0, 5);
  EXPECT_EQ(s.speed, -32767);
  EXPECT_TRUE(s.speed_saturated);
}

// J§1.3.2 0x6010 reading 1 (CiA 406): writing P makes the current position read P.
TEST(PositionPipelineRotary, J1_3_2_PresetCurrentReadsP) {
  auto p = make(FamilyId::novotechnik_rotary);
  p.update(0.25, 0.0);
  EXPECT_EQ(p.preset(100), kOk);
  EXPECT_EQ(p.last().value, 100);
  EXPECT_EQ(p.update(0.25, 0.001).position, 100U);
  EXPECT_EQ(p.update(0.5, 0.002).position, 100U + 0x1000U);
  EXPECT_EQ(p.offset(), 100 - 0x1000);
  EXPECT_EQ(p.preset(0x3FF0), kOk);  // at 0x2000 physical
  EXPECT_EQ(p.update(0.75, 0.003).position, 0xFF0U);  // wraps modulo the total range
  EXPECT_EQ(p.preset(0x4000), kValueExceeded);
  EXPECT_EQ(p.preset(-1), kValueExceeded);
}

// J§1.3.2 0x6010 reading 2 (J§1.4.6.1 hint): the preset is added, range [P, P+total).
TEST(PositionPipelineRotary, J1_3_2_PresetOffsetAddedSwitch) {
  auto s = PositionSettings::defaults(FamilyId::novotechnik_rotary);
  s.preset_mode = PresetMode::offset_added;
  PositionPipeline p(s);
  p.update(0.25, 0.0);
  EXPECT_EQ(p.preset(100), kOk);
  EXPECT_EQ(p.update(0.25, 0.001).value, 0x1000 + 100);
  EXPECT_EQ(p.update(0.999999, 0.002).value, 0x3FFF + 100);
}

// J§1.8: position or sensor error -> position 0x7FF0, speed 0.
TEST(PositionPipelineRotary, J_1_8_MeasurementErrorValue) {
  auto p = make(FamilyId::novotechnik_rotary);
  run(p, 1.0, 5);
  p.set_measurement_error(true);
  const auto s = p.update(0.1, 0.01);
  EXPECT_EQ(s.position, 0x7FF0U);
  EXPECT_EQ(s.speed, 0);
  EXPECT_TRUE(s.error_value);
  p.set_measurement_error(false);
  EXPECT_FALSE(p.update(0.1, 0.011).error_value);
}

// ---------------- Multiturn (E) ----------------

// E§4.2: 0x6001 = 0x10000, 0x6002 = 0x2C0000 (44 turns); 0x600C raw.
TEST(PositionPipelineMultiturn, E_4_2_SixteenBitTimesFortyFour) {
  auto p = make(FamilyId::novotechnik_multiturn);
  EXPECT_EQ(p.settings().total_range, 0x2C0000U);
  const auto s = p.update(2.5, 0.0);
  EXPECT_EQ(s.position, 0x28000U);
  EXPECT_EQ(s.raw, 0x28000U);
  EXPECT_EQ(s.range, RangeState::in_range);
}

// E§5.3 bit 2 = 0 scaling on (as printed, E§5.3); E§5.4/§5.5 coupling.
TEST(PositionPipelineMultiturn, E_5_3_ScalingBitZeroIsOn) {
  auto p = make(FamilyId::novotechnik_multiturn);
  const auto& s = p.settings();
  EXPECT_TRUE(p.scaling_active());
  EXPECT_EQ(check_scaling_write_allowed(s, 0x0000), kOk);
  EXPECT_EQ(check_scaling_write_allowed(s, 0x0004), kWrongState);
  EXPECT_EQ(check_units_per_rev(s, 0x10001), kValueExceeded);
  EXPECT_EQ(check_total_range(s, 0x2C0001), kValueExceeded);
  EXPECT_EQ(coupled_total_range(s, 0x1000), 0x2C000U);
  EXPECT_EQ(coupled_units_per_rev(s, 0x2C000), 0x1000U);
  p.settings().units_per_rev = 0x1000;
  p.settings().total_range = 0x2C000;
  auto out = p.update(2.5, 0.0);
  EXPECT_EQ(out.position, 0x2800U);
  EXPECT_EQ(out.raw, 0x28000U);  // 0x600C: without scaling
  p.settings().operating_parameter = 0x0004;  // scaling off
  EXPECT_EQ(p.update(2.5, 0.001).position, 0x28000U);
}

// E§5.2: 0x2010/2 <-> 0x6031/2 coupling table (E§5.2 for the non-unique reverse).
TEST(PositionPipelineMultiturn, E_5_2_SpeedFilterIntegrationCoupling) {
  EXPECT_EQ(integration_ms_for_speed_filter(0), 0);
  EXPECT_EQ(integration_ms_for_speed_filter(1), 0);
  EXPECT_EQ(integration_ms_for_speed_filter(3), 1);
  EXPECT_EQ(integration_ms_for_speed_filter(5), 3);
  EXPECT_EQ(integration_ms_for_speed_filter(8), 25);
  EXPECT_EQ(speed_filter_for_integration_ms(0), 0);
  EXPECT_EQ(speed_filter_for_integration_ms(1), 3);
  EXPECT_EQ(speed_filter_for_integration_ms(6), 6);
  EXPECT_EQ(speed_filter_for_integration_ms(12), 7);
  EXPECT_EQ(check_speed_integration_ms(0), kOk);
  EXPECT_EQ(check_speed_integration_ms(25), kOk);
  EXPECT_EQ(check_speed_integration_ms(4), kValueExceeded);
  EXPECT_EQ(check_speed_filter(8), kOk);
  EXPECT_EQ(check_speed_filter(9), kValueExceeded);
  EXPECT_EQ(check_position_filter(7), kOk);
  EXPECT_EQ(check_position_filter(8), kValueExceeded);
}

// E§3.4, E§4.2 0x6031/2: speed in 0.1 deg/s averaged over the integration time.
TEST(PositionPipelineMultiturn, E_4_2_SpeedAveragedOverIntegrationTime) {
  for (const std::uint16_t ms : {std::uint16_t{1}, std::uint16_t{25}}) {
    auto p = make(FamilyId::novotechnik_multiturn);
    p.settings().speed_integration_ms = ms;
    PositionSample s;
    // 1 turn/s from 50 ms to 60 ms, standing still before and after.
    for (int i = 0; i <= 70; ++i) {
      const double t = i * 0.001;
      const double turns = 2.0 + (t < 0.05 ? 0.0 : (t < 0.06 ? t - 0.05 : 0.01));
      s = p.update(turns, t);
    }
    // Over 25 ms (45..70 ms) the shaft moved 0.01 turn: 0.4 turn/s = 1440.
    EXPECT_EQ(s.speed, ms == 25 ? 1440 : 0) << ms;
  }
}

// E§5.1: position filter 0x2010/1 averages 2^n positions.
TEST(PositionPipelineMultiturn, E_5_1_PositionFilter) {
  auto p = make(FamilyId::novotechnik_multiturn);
  p.settings().position_filter = 3;  // 8 positions
  PositionSample s;
  for (int i = 0; i < 8; ++i) s = p.update(i < 7 ? 1.0 : 2.0, i * 0.001);
  EXPECT_EQ(s.position, 0x10000U + 0x10000U / 8U);
}

// E§10.1 bits 10/11: Info in the last revolution before a limit (E§9.1, E§10.1).
TEST(PositionPipelineMultiturn, E_10_1_InfoInLastRevolution) {
  auto p = make(FamilyId::novotechnik_multiturn);
  EXPECT_EQ(p.update(0.5, 0.0).range, RangeState::info_under);
  EXPECT_EQ(p.update(43.5, 0.001).range, RangeState::info_over);
  EXPECT_EQ(p.update(43.5, 0.001).position, 0x2B8000U);  // still a valid position
  EXPECT_EQ(range_status_bits(RangeState::info_over).status_1002, 1U << 10);
  EXPECT_EQ(range_status_bits(RangeState::info_under).status_1002, 1U << 11);
}

// E§9.1 0x5051/2/x: Warning beyond a limit, sentinel positions, speed 0.
TEST(PositionPipelineMultiturn, E_9_1_WarningSentinels) {
  auto p = make(FamilyId::novotechnik_multiturn);
  run(p, 1.0, 10, 0.0, 43.9);
  auto s = p.update(44.5, 0.02);
  EXPECT_EQ(s.range, RangeState::warning_over);
  EXPECT_EQ(s.position, 0x7FFFFFF8U);
  EXPECT_EQ(s.speed, 0);
  EXPECT_TRUE(s.error_value);
  const auto bits = range_status_bits(s.range);
  EXPECT_EQ(bits.status_1002, 1U << 20);
  EXPECT_EQ(bits.warnings_6505, 1U << 13);
  s = p.update(-0.5, 0.021);
  EXPECT_EQ(s.range, RangeState::warning_under);
  EXPECT_EQ(s.position, 0x80000008U);
  EXPECT_EQ(range_status_bits(s.range).warnings_6505, 1U << 12);
  // A warning does not latch: back in range reads a valid position again.
  EXPECT_EQ(p.update(10.0, 0.022).position, 0xA0000U);
}

// E§9.1 0x5051/1/x and E§4.3 0x2100: the Error latches until back in range and reset.
TEST(PositionPipelineMultiturn, E_9_1_ErrorLatchesUntilPositionErrorReset) {
  auto p = make(FamilyId::novotechnik_multiturn);
  auto s = p.update(46.0, 0.0);
  EXPECT_EQ(s.range, RangeState::error_over);
  EXPECT_EQ(s.position, 0x7FFFFFF8U);
  EXPECT_EQ(range_status_bits(s.range).alarms_6503, 1U << 13);
  EXPECT_EQ(range_status_bits(s.range).status_1002, 1U << 12);
  EXPECT_FALSE(p.position_error_reset());  // still out of range: precondition not met
  s = p.update(20.0, 0.001);
  EXPECT_EQ(s.range, RangeState::error_over);  // back in range, still latched
  EXPECT_EQ(s.position, 0x7FFFFFF8U);
  EXPECT_TRUE(p.position_error_reset());
  s = p.update(20.0, 0.002);
  EXPECT_EQ(s.range, RangeState::in_range);
  EXPECT_EQ(s.position, 0x140000U);
  s = p.update(-3.0, 0.003);
  EXPECT_EQ(s.range, RangeState::error_under);
  EXPECT_EQ(s.position, 0x80000008U);
  EXPECT_EQ(range_status_bits(s.range).alarms_6503, 1U << 12);
}

// E§9.1 0x5051/1/0: measurement error -> 0x7FFFFFFC.
TEST(PositionPipelineMultiturn, E_9_1_MeasurementErrorValue) {
  auto p = make(FamilyId::novotechnik_multiturn);
  p.set_measurement_error(true);
  const auto s = p.update(5.0, 0.0);
  EXPECT_EQ(s.position, 0x7FFFFFFCU);
  EXPECT_EQ(s.raw, 0x7FFFFFFCU);
}

// E§4.2 0x6003/0x6509 (E§4.2): CiA 406 preset, INTEGER32 output without wrap.
TEST(PositionPipelineMultiturn, E_4_2_PresetAndOffsetNoWrap) {
  auto p = make(FamilyId::novotechnik_multiturn);
  p.update(10.0, 0.0);
  EXPECT_EQ(p.preset(0), kOk);
  EXPECT_EQ(p.offset(), -0xA0000);
  const auto s = p.update(9.0, 0.001);
  EXPECT_EQ(s.value, -0x10000);
  EXPECT_EQ(s.position, 0xFFFF0000U);
  EXPECT_EQ(p.preset(0x2C0000), kValueExceeded);
}

// ---------------- ifm (F) ----------------

// F§7.5 0x6501/0x6502 "see label": default 12 bit x 12 bit; 0x2102 default 0x1000000.
TEST(PositionPipelineIfm, F_7_5_DefaultResolutionWrapsAtTotal) {
  auto p = make(FamilyId::ifm_rm);
  EXPECT_EQ(p.settings().total_range, 0x1000000U);
  EXPECT_EQ(p.update(1.5, 0.0).position, 6144U);
  EXPECT_EQ(p.update(4096.25, 0.001).position, 1024U);
  p.settings().operating_parameter = 0x0001;  // F§7.5 CS: ccw
  EXPECT_EQ(p.update(1.5, 0.002).position, 0xFFFFFFU - 6144U);
}

// F§7.5 SFC bit 2 = 1 enables 0x6001/0x6002 scaling.
TEST(PositionPipelineIfm, F_7_5_ScalingFunction) {
  auto p = make(FamilyId::ifm_rm);
  p.settings().units_per_rev = 1024;
  p.settings().total_range = 1024U * 4096U;
  EXPECT_EQ(p.update(1.5, 0.0).position, 6144U);
  p.settings().operating_parameter = 0x0004;
  EXPECT_EQ(p.update(1.5, 0.001).position, 1536U);
}

// F§7.4 0x2100 bits 1/2, 0x2104/0x2105: bit 30 at/below min, bit 31 at/above max.
TEST(PositionPipelineIfm, F_7_4_LimitSwitchBits) {
  auto p = make(FamilyId::ifm_rm);
  auto& s = p.settings();
  s.limit_min = 100;
  s.limit_max = 5000;
  EXPECT_EQ(p.update(50.0 / 4096, 0.0).position, 50U);  // disabled: plain value
  s.limit_min_enabled = true;
  s.limit_max_enabled = true;
  EXPECT_EQ(p.update(100.0 / 4096, 0.001).position, (1U << 30) | 100U);
  EXPECT_EQ(p.update(101.0 / 4096, 0.002).position, 101U);
  EXPECT_EQ(p.update(4999.0 / 4096, 0.003).position, 4999U);
  EXPECT_EQ(p.update(5000.0 / 4096, 0.004).position, (1U << 31) | 5000U);
  EXPECT_EQ(p.last().value, 5000);  // CAM / work area see the value without the bits
  EXPECT_EQ(check_ifm_limit_switch(s, 0x1000000), kOk);
  EXPECT_EQ(check_ifm_limit_switch(s, 0x1000001), kValueExceeded);
}

// F§7.4 0x3010 speed control: off by default; 0x3011/0x6030 in digits/s; F§7.5 0x6030 saturates.
TEST(PositionPipelineIfm, F_7_4_SpeedEnableFilterAndSaturation) {
  auto p = make(FamilyId::ifm_rm);
  EXPECT_EQ(run(p, 1.0, 20).speed, 0);
  auto q = make(FamilyId::ifm_rm);
  q.settings().speed_enabled = true;
  EXPECT_EQ(run(q, 1.0, 20).speed, 4096);
  auto r = make(FamilyId::ifm_rm);
  r.settings().speed_enabled = true;
  const auto s = run(r, 10.0, 20);
  EXPECT_EQ(s.speed, 32767);
  EXPECT_TRUE(s.speed_saturated);
  EXPECT_EQ(s.speed32, 40960);
  EXPECT_EQ(check_ifm_speed_mode(2), kOk);
  EXPECT_EQ(check_ifm_speed_mode(3), kValueExceeded);
}

// F§7.4 0x3010/2: filter 0 = 5 ms, 2 = 500 ms.
TEST(PositionPipelineIfm, F_7_4_SpeedFilterWindow) {
  for (const std::uint8_t mode : {std::uint8_t{0}, std::uint8_t{2}}) {
    auto p = make(FamilyId::ifm_rm);
    p.settings().speed_enabled = true;
    p.settings().speed_mode = mode;
    PositionSample s;
    // 1 turn/s for 100 ms, then standing still for 100 ms.
    for (int i = 0; i <= 600; ++i) {
      const double t = i * 0.001;
      const double turns = t < 0.4 ? 0.0 : (t < 0.5 ? t - 0.4 : 0.1);
      s = p.update(turns, t);
      if (i == 550) break;
    }
    // 5 ms window: standing still. 500 ms window (50..550 ms): 0.1 turn / 0.5 s.
    EXPECT_EQ(s.speed, mode == 0 ? 0 : 819) << int{mode};
  }
}

// F§7.4 0x2101/0x2102: AU <= PAU; GA <= PGA, GA = PGA x AU / PAU, multiple of PAU below PGA.
TEST(PositionPipelineIfm, F_7_4_TotalResolutionRules) {
  const auto s = PositionSettings::defaults(FamilyId::ifm_rm);
  EXPECT_EQ(check_ifm_resolution_per_rev(s, 4096), kOk);
  EXPECT_EQ(check_ifm_resolution_per_rev(s, 4097), kValueExceeded);
  EXPECT_EQ(ifm_total_resolution_for(s, 1024), 4194304U);
  EXPECT_EQ(check_ifm_total_resolution(s, 4194304, 1024), kOk);
  EXPECT_EQ(check_ifm_total_resolution(s, 4194305, 1024), kValueExceeded);
  EXPECT_EQ(check_ifm_total_resolution(s, 0x1000001, 4096), kValueExceeded);
  EXPECT_EQ(check_ifm_total_resolution(s, 8192, 1024, false), kOk);
  EXPECT_EQ(check_ifm_total_resolution(s, 5000, 1024, false), kValueExceeded);
}

// F§7.4 0x2103: the preset must not exceed the total resolution; F§7.5 0x6509 offset.
TEST(PositionPipelineIfm, F_7_4_PresetAndOffset) {
  auto p = make(FamilyId::ifm_rm);
  p.update(2.0, 0.0);
  EXPECT_EQ(p.preset(0x1000000), kValueExceeded);
  EXPECT_EQ(p.preset(4096), kOk);
  EXPECT_EQ(p.offset(), 4096 - 8192);
  EXPECT_EQ(p.update(3.0, 0.001).position, 8192U);
}

}  // namespace
}  // namespace cobridge::sim
