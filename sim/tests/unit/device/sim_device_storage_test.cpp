// SimDevice non-volatile storage: 0x1010 'save', 0x1011 'load', 'kill',
// ifm 0x2300, per serial under the state directory.
#include <fstream>

#include "sim_bench.hpp"

namespace cobridge::sim::test {
namespace {

constexpr std::uint32_t kSave = 0x65766173;
constexpr std::uint32_t kLoad = 0x64616F6C;
constexpr std::uint32_t kKill = 0x6C6C696B;

// E§11 table: /2 stores the communication parameters only; a power cycle
// keeps them and loses everything not stored.
TEST(SimDeviceStorage, SavedKeptUnsavedLost_E11) {
  const auto dir = temp_state_dir("saved");
  Bench b("MC1-2800", "novotechnik-multiturn.eds", {}, dir);
  b.power_on();
  ASSERT_EQ(b.write_u16(0x1017, 0, 50).data[0], 0x60);  // comm
  ASSERT_EQ(b.write_u8(0x6301, 1, 0x03).data[0], 0x60);  // application
  ASSERT_EQ(b.write_u32(0x1010, 2, kSave).data[0], 0x60);
  EXPECT_TRUE(std::filesystem::exists(b.device->nv_path()));
  EXPECT_EQ(b.device->nv_path().filename(), "novotechnik-multiturn-305419896.nv");
  b.power_cycle();
  EXPECT_EQ(Bench::value(b.read(0x1017, 0)) & 0xFFFFu, 50u);
  EXPECT_EQ(Bench::value(b.read(0x6301, 1)) & 0xFFu, 0u);
  std::filesystem::remove_all(dir);
}

// A restarted simulator (a new SimDevice on the same state directory) comes
// up with exactly what was stored.
TEST(SimDeviceStorage, NewProcessSeesStoredImage_J1_10) {
  const auto dir = temp_state_dir("process");
  {
    Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds", {}, dir);
    b.power_on();
    ASSERT_EQ(b.write_u16(0x6000, 0, 0x0005).data[0], 0x60);
    ASSERT_EQ(b.write_u32(0x1010, 3, kSave).data[0], 0x60);
  }
  Bench b2("RFC-4800", "novotechnik-rfc4800-1ch.eds", {}, dir);
  b2.power_on();
  EXPECT_EQ(Bench::value(b2.read(0x6000, 0)) & 0xFFFFu, 0x0005u);
  Bench other("RFC-4800", "novotechnik-rfc4800-1ch.eds", [] { DeviceSpec s; s.serial = 99; return s; }(), dir);
  other.power_on();
  EXPECT_EQ(Bench::value(other.read(0x6000, 0)) & 0xFFFFu, 0u);  // per serial
  std::filesystem::remove_all(dir);
}

// J§1.10, E§11: Novotechnik 'load' reverts RAM to the last saved image.
TEST(SimDeviceStorage, LoadRevertsToSavedImage_J1_10) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds", {}, temp_state_dir("load"));
  b.power_on();
  ASSERT_EQ(b.write_u16(0x6000, 0, 0x0004).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x1010, 3, kSave).data[0], 0x60);
  ASSERT_EQ(b.write_u16(0x6000, 0, 0x0001).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x1011, 3, kLoad).data[0], 0x60);
  EXPECT_EQ(Bench::value(b.read(0x6000, 0)) & 0xFFFFu, 0x0004u);
  std::filesystem::remove_all(temp_state_dir("load"));
}

// J§1.10 'kill': erase NV and restore the defaults (custom factory node-ID
// kept on the non-RSX/RFX series).
TEST(SimDeviceStorage, KillRestoresDefaults_J1_10) {
  DeviceSpec spec;
  spec.node_id = 5;  // a custom factory node-ID
  const auto dir = temp_state_dir("kill");
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds", spec, dir);
  b.power_on();
  ASSERT_EQ(b.write_u16(0x6000, 0, 0x0004).data[0], 0x60);
  ASSERT_EQ(b.write_u8(0x2000, 0, 9).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x1010, 1, kSave).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x1010, 4, kSave).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x1010, 1, kKill).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x1010, 4, kKill).data[0], 0x60);
  EXPECT_EQ(Bench::value(b.read(0x6000, 0)) & 0xFFFFu, 0u);
  EXPECT_EQ(Bench::value(b.read(0x2000, 0)) & 0xFFu, 5u);
  b.power_cycle();
  EXPECT_EQ(b.device->node_id(), 5);
  EXPECT_EQ(Bench::value(b.read(0x6000, 0)) & 0xFFFFu, 0u);
  std::filesystem::remove_all(dir);
}

// J§1.6.1: node-ID by SDO 0x2000 + 'save' on 0x1010/4 (RSX/RFX: /1) ->
// active after power-up.
TEST(SimDeviceStorage, NodeIdSavedSubIndexPerSeries_J1_6_1) {
  const auto dir = temp_state_dir("nodeid");
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds", {}, dir);
  b.power_on();
  ASSERT_EQ(b.write_u8(0x2000, 0, 0x40).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x1010, 1, kSave).data[0], 0x60);  // /1 does not cover it
  b.power_cycle();
  EXPECT_EQ(b.device->node_id(), 0x7F);
  ASSERT_EQ(b.write_u8(0x2000, 0, 0x40).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x1010, 4, kSave).data[0], 0x60);
  b.power_cycle();
  EXPECT_EQ(b.device->node_id(), 0x40);
  EXPECT_EQ(b.rec.frames.back(), Frame::make(0x740, {0x00}));

  DeviceSpec spec;
  spec.serial = 7;
  Bench x("RSX-7900", "novotechnik-rsx7900-1ch.eds", spec, dir);
  x.power_on();
  ASSERT_EQ(x.write_u8(0x2000, 0, 0x22).data[0], 0x60);
  ASSERT_EQ(x.write_u32(0x1010, 1, kSave).data[0], 0x60);
  x.power_cycle();
  EXPECT_EQ(x.device->node_id(), 0x22);
  std::filesystem::remove_all(dir);
}

// CiA 406 preset (CiA 406) survives a power cycle when saved (the device
// keeps the offset beside it).
TEST(SimDeviceStorage, PresetSurvivesPowerCycle_E11) {
  const auto dir = temp_state_dir("preset");
  Bench b("MC1-2800", "novotechnik-multiturn.eds", {}, dir);
  b.power_on();
  ASSERT_EQ(b.write_u32(0x6003, 0, 1000).data[0], 0x60);
  b.run_for(2ms);
  EXPECT_EQ(Bench::value(b.read(0x6004, 0)), 1000u);
  ASSERT_EQ(b.write_u32(0x1010, 3, kSave).data[0], 0x60);
  b.power_cycle();
  b.run_for(2ms);
  EXPECT_EQ(Bench::value(b.read(0x6004, 0)), 1000u);
  std::filesystem::remove_all(dir);
}

// F§6.3.4: 0x2300 <- 0x55AAAA55 saves, confirms, then resets (boot-up);
// the saved node number is active at once.
TEST(SimDeviceStorage, IfmSaveWithReset_F6_3_4) {
  const auto dir = temp_state_dir("ifm2300");
  Bench b("RM9000", "ifm-rm8-rm9.eds", {}, dir);
  b.power_on();
  ASSERT_EQ(b.write_u8(0x3000, 0, 0x09).data[0], 0x60);
  const std::size_t from = b.rec.frames.size();
  b.deliver(Frame::make8(0x620, {0x23, 0x00, 0x23, 0x00, 0x55, 0xAA, 0xAA, 0x55}));
  ASSERT_GE(b.rec.frames.size(), from + 2);
  EXPECT_EQ(b.rec.frames[from], Frame::make8(0x5A0, {0x60, 0x00, 0x23, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(b.rec.frames[from + 1], Frame::make(0x70A, {0x00}));
  EXPECT_EQ(b.device->node_id(), 10);
  b.power_cycle();
  EXPECT_EQ(b.device->node_id(), 10);
  std::filesystem::remove_all(dir);
}

// F§6.3.5, F§6.3: ifm 'load' = factory settings, active after a reset,
// EEPROM untouched (a power cycle without 'save' brings the stored values back).
TEST(SimDeviceStorage, IfmLoadIsFactoryAfterReset_F6_3_5) {
  const auto dir = temp_state_dir("ifmload");
  Bench b("RM9000", "ifm-rm8-rm9.eds", {}, dir);
  b.power_on();
  ASSERT_EQ(b.write_u16(0x6200, 0, 500).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x1010, 1, kSave).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x1011, 1, kLoad).data[0], 0x60);
  EXPECT_EQ(Bench::value(b.read(0x6200, 0)) & 0xFFFFu, 500u);  // not yet
  b.nmt(0x81, 32);
  EXPECT_EQ(Bench::value(b.read(0x6200, 0)) & 0xFFFFu, 100u);
  b.power_cycle();
  EXPECT_EQ(Bench::value(b.read(0x6200, 0)) & 0xFFFFu, 500u);
  std::filesystem::remove_all(dir);
}

// F§6.3.5, F§7.3 0x1011: after 'load' the NMT reset node activates the
// factory settings in every area, the communication objects included (the
// event timer 0x1800/5 and its twins 0x6200 / 0x2200, F§7.3, F§7.5 0x6200) and the
// preset (offset 0), and TPDO1 runs at the factory 100 ms; the EEPROM still
// holds the saved image, which a power cycle brings back.
TEST(SimDeviceStorage, IfmLoadResetNodeRestoresCommunicationArea_F6_3_5) {
  const auto dir = temp_state_dir("ifmloadcomm");
  DeviceSpec spec;
  spec.node_id = 5;
  Bench b("RM9000", "ifm-rm8-rm9.eds", spec, dir);
  b.power_on();
  ASSERT_EQ(b.write_u32(0x1800, 5, 50).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x6003, 0, 1000).data[0], 0x60);  // preset
  b.run_for(2ms);
  ASSERT_EQ(Bench::value(b.read(0x6004, 0)), 1000u);
  ASSERT_EQ(b.write_u32(0x1010, 1, kSave).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x1011, 1, kLoad).data[0], 0x60);
  EXPECT_EQ(Bench::value(b.read(0x1800, 5)), 50u);  // F§7.3: not before a reset
  b.nmt(0x81, 5);
  b.run_for(2ms);
  EXPECT_EQ(Bench::value(b.read(0x1800, 5)), 100u);
  EXPECT_EQ(Bench::value(b.read(0x6200, 0)) & 0xFFFFu, 100u);
  EXPECT_EQ(Bench::value(b.read(0x2200, 0)) & 0xFFFFu, 100u);
  EXPECT_EQ(Bench::value(b.read(0x6003, 0)), 0u);
  EXPECT_EQ(Bench::value(b.read(0x6509, 0)), 0u);
  EXPECT_EQ(Bench::value(b.read(0x6004, 0)), 0u);  // constant:0 shaft at count 0, no offset
  b.nmt(0x01, 5);
  const std::size_t from = b.rec.frames.size();
  b.run_for(1000ms);
  const auto pdos = b.frames_with_id(0x185, from);
  EXPECT_GE(pdos.size(), 9u);
  EXPECT_LE(pdos.size(), 11u);
  b.power_cycle();
  b.run_for(2ms);
  EXPECT_EQ(Bench::value(b.read(0x1800, 5)), 50u);
  EXPECT_EQ(Bench::value(b.read(0x2200, 0)) & 0xFFFFu, 50u);  // the mirror after power-up too
  EXPECT_EQ(Bench::value(b.read(0x6004, 0)), 1000u);
  std::filesystem::remove_all(dir);
}

// The file format: `index:sub=hex` lines, written atomically (no .tmp left).
TEST(SimDeviceStorage, FileFormat_NvStore) {
  const auto dir = temp_state_dir("format");
  Bench b("MC1-2800", "novotechnik-multiturn.eds", {}, dir);
  b.power_on();
  ASSERT_EQ(b.write_u16(0x1017, 0, 0x1234).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x1010, 2, kSave).data[0], 0x60);
  std::ifstream in(b.device->nv_path());
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("1017:0=1234"), std::string::npos) << text;
  EXPECT_FALSE(std::filesystem::exists(b.device->nv_path().string() + ".tmp"));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cobridge::sim::test
