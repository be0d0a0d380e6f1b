// SimDevice and the bus state: Linux CAN error frames (<linux/can/error.h>)
// as the simulator delivers them for control `bus-error`; the device's CAN
// controller goes error passive / bus-off and reports it as J§1.8.1 and
// E§9.1 print it (0x8120, 0x8140) with the 0x1002 bits of J§1.9.1, E§10.1.
#include <linux/can/error.h>

#include "sim_bench.hpp"

namespace cobridge::sim::test {
namespace {

Frame error_frame(std::uint32_t cls, std::uint8_t crtl = 0) {
  Frame f;
  f.flags = Frame::kFlagError;
  f.id = cls;
  f.len = CAN_ERR_DLC;
  f.data[1] = crtl;
  return f;
}
const Frame kPassive = error_frame(CAN_ERR_CRTL | CAN_ERR_CNT, CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE);
const Frame kWarning = error_frame(CAN_ERR_CRTL | CAN_ERR_CNT, CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING);
const Frame kActive = error_frame(CAN_ERR_CRTL | CAN_ERR_CNT, CAN_ERR_CRTL_ACTIVE);
const Frame kBusOff = error_frame(CAN_ERR_BUSOFF);
const Frame kRestarted = error_frame(CAN_ERR_RESTARTED);

std::uint32_t status_1002(const Bench& b) {
  return b.device->object_dictionary()->get_u32(0x1002, 0).value_or(0xDEADBEEF);
}
std::uint8_t error_register(const Bench& b) { return b.device->object_dictionary()->get_u8(0x1001, 0).value_or(0xFF); }

// J§1.8.1 rows 0x8120 / 0x8140 (register byte 1, bytes 3-7 zero), J§1.9.1
// 0x1002 bit 4 error passive, bit 3 bus-off, bit 2 bus-off timer started.
TEST(SimDeviceBusError, RotaryPassiveBusOffRecovery_J1_8_1_J1_9_1) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  ASSERT_EQ(b.write_u16(0x1017, 0, 10).data[0], 0x60);  // heartbeat, to watch the silence
  std::size_t from = b.rec.frames.size();
  b.deliver(kWarning);
  EXPECT_TRUE(b.frames_with_id(0xFF, from).empty());  // no row for error warning
  b.deliver(kPassive);
  auto emcy = b.frames_with_id(0xFF, from);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(emcy[0], Frame::make8(0xFF, {0x20, 0x81, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00}));
  EXPECT_EQ(status_1002(b) & 0x1Cu, 0x10u);
  EXPECT_EQ(error_register(b), 0x11);  // CiA 301 0x1001: generic + communication
  b.deliver(kPassive);  // still passive: once per event
  EXPECT_EQ(b.frames_with_id(0xFF, from).size(), 1u);

  // Back to error active: bit cleared, no EMCY (neither table has a row).
  b.deliver(kActive);
  EXPECT_EQ(status_1002(b) & 0x1Cu, 0u);
  EXPECT_EQ(error_register(b), 0);
  EXPECT_EQ(b.frames_with_id(0xFF, from).size(), 1u);

  // Bus-off: nothing sent, nothing received.
  b.deliver(kBusOff);
  EXPECT_EQ(status_1002(b) & 0x1Cu, 0x0Cu);
  from = b.rec.frames.size();
  b.run_for(100ms);
  EXPECT_EQ(b.rec.frames.size(), from);
  const Frame answer = b.read(0x1018, 4);
  EXPECT_EQ(answer.id, 0u);  // no SDO answer
  b.nmt(0x01, 0x7F);         // NMT start not seen either
  EXPECT_EQ(b.device->nmt_state(), canopen::NmtState::pre_operational);

  // The restart: EMCY 0x8140, heartbeats again, SDO answered.
  b.deliver(kRestarted);
  emcy = b.frames_with_id(0xFF, from);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(emcy[0], Frame::make8(0xFF, {0x40, 0x81, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00}));
  EXPECT_EQ(status_1002(b) & 0x1Cu, 0u);
  EXPECT_EQ(error_register(b), 0);
  b.run_for(30ms);
  EXPECT_GE(b.frames_with_id(0x77F, from).size(), 2u);
  EXPECT_EQ(Bench::value(b.read(0x1018, 4)), 0x12345678u);
}

// E§9.1 rows 0x8120 / 0x8140 (byte 2 = 0, level Hard: sent even with the
// 0x2104 filter at 3), E§10.1 bits 16 / 17 / 18. An error-active frame
// after bus-off also means the controller is back.
TEST(SimDeviceBusError, MultiturnPassiveBusOffRecovery_E9_1_E10_1) {
  Bench b("MC1-2800", "novotechnik-multiturn.eds");
  b.power_on();
  ASSERT_EQ(b.write_u8(0x2104, 0, 3).data[0], 0x60);
  std::size_t from = b.rec.frames.size();
  b.deliver(kPassive);
  auto emcy = b.frames_with_id(0xFF, from);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(emcy[0], Frame::make8(0xFF, {0x20, 0x81, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}));
  EXPECT_EQ(status_1002(b) & 0x70000u, 0x10000u);
  b.deliver(kBusOff);
  EXPECT_EQ(status_1002(b) & 0x70000u, 0x60000u);
  from = b.rec.frames.size();
  b.deliver(kActive);
  emcy = b.frames_with_id(0xFF, from);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(emcy[0], Frame::make8(0xFF, {0x40, 0x81, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}));
  EXPECT_EQ(status_1002(b) & 0x70000u, 0u);
}

// ifm (F documents no EMCY codes, F§4): the CiA 301 codes with the
// error register (generic + communication while passive), marked (ext).
TEST(SimDeviceBusError, IfmCia301Codes_B6) {
  Bench b("RM9000", "ifm-rm8-rm9.eds");
  b.power_on();
  std::size_t from = b.rec.frames.size();
  b.deliver(kPassive);
  auto emcy = b.frames_with_id(0xA0, from);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(emcy[0], Frame::make8(0xA0, {0x20, 0x81, 0x11, 0x00, 0x00, 0x00, 0x00, 0x00}));
  b.deliver(kBusOff);
  b.deliver(kRestarted);
  emcy = b.frames_with_id(0xA0, from);
  ASSERT_EQ(emcy.size(), 2u);
  EXPECT_EQ(emcy[1], Frame::make8(0xA0, {0x40, 0x81, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}));
  // F§7.3 0x1003: the pre-defined error field keeps them, newest first.
  EXPECT_EQ(Bench::value(b.read(0x1003, 1)), 0x8140u);
  EXPECT_EQ(Bench::value(b.read(0x1003, 2)), 0x8120u);
}

// A pulled cable (control `silence`) sees no bus state; a power cycle gives
// a fresh, error-active controller.
TEST(SimDeviceBusError, SilentIgnoresAndPowerCycleClears_J1_9_1) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  b.device->set_silent(true);
  b.deliver(kPassive);
  b.device->set_silent(false);
  EXPECT_EQ(status_1002(b) & 0x1Cu, 0u);
  b.deliver(kBusOff);
  EXPECT_EQ(status_1002(b) & 0x1Cu, 0x0Cu);
  const std::size_t from = b.rec.frames.size();
  b.power_cycle();
  EXPECT_EQ(status_1002(b) & 0x1Cu, 0u);
  ASSERT_EQ(b.frames_with_id(0x77F, from).size(), 1u);  // boot-up went out
}

}  // namespace
}  // namespace cobridge::sim::test
