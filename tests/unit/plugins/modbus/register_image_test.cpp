// The register image of the Modbus output: what a sample puts where, word
// order, data age, bus counters, and the seqlock under a concurrent writer.
// Register layout: docs/modbus.md; 32-bit values as two registers per
// Modbus Application Protocol V1.1b3 §4.2 (big-endian inside a register).
#include "register_image.hpp"

#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <thread>

namespace cobridge::modbus {
namespace {

constexpr std::uint64_t kNow = 1'700'000'000'000'000'000ull;  // realtime ns

cobridge_sample tpdo(std::uint16_t device, std::uint32_t seq, std::int64_t position, std::uint64_t rx_ns) {
  cobridge_sample s{};
  s.device_index = device;
  s.bus_index = 0;
  s.node_id = static_cast<std::uint8_t>(device + 1);
  s.kind = COBRIDGE_SAMPLE_TPDO;
  s.sequence = seq;
  s.rx_timestamp_ns = rx_ns;
  s.valid = COBRIDGE_VALID_POSITION | COBRIDGE_VALID_SPEED;
  s.position = position;
  s.speed = -2;
  return s;
}

std::array<std::uint16_t, kDeviceStride> slot(const RegisterImage& img, std::uint16_t n, std::uint64_t now = kNow) {
  std::array<std::uint16_t, kDeviceStride> r{};
  EXPECT_EQ(img.read(device_base(n), r, ReadTime{now, 0}, false), ReadStatus::kOk);
  return r;
}

// docs/modbus.md word order, "big": high word first (Modbus convention, MBAP §4.2 per register).
TEST(RegisterImage, BigWordOrderPutsHighWordFirst_MBAP_4_2) {
  RegisterImage img(ImageOptions{});
  img.apply(tpdo(0, 7, 0x12345678, kNow));
  const auto r = slot(img, 0);
  EXPECT_EQ(r[0], 0x1234);
  EXPECT_EQ(r[1], 0x5678);
  EXPECT_EQ(r[2], 0xFFFF);  // speed -2 as int32, high word
  EXPECT_EQ(r[3], 0xFFFE);
  EXPECT_EQ(r[12], 0x0000);  // sequence 7
  EXPECT_EQ(r[13], 0x0007);
}

// docs/modbus.md word order, "little": low word first.
TEST(RegisterImage, LittleWordOrderPutsLowWordFirst_MBAP_4_2) {
  ImageOptions o;
  o.word_order = WordOrder::kLittle;
  RegisterImage img(o);
  img.apply(tpdo(0, 0x00010002, -1000, kNow));
  const auto r = slot(img, 0);
  const auto pos = static_cast<std::uint32_t>(-1000);
  EXPECT_EQ(r[0], pos & 0xFFFF);
  EXPECT_EQ(r[1], pos >> 16);
  EXPECT_EQ(r[12], 0x0002);
  EXPECT_EQ(r[13], 0x0001);
  std::array<std::uint16_t, 1> wo{};
  ASSERT_EQ(img.read(12, wo, ReadTime{}, false), ReadStatus::kOk);
  EXPECT_EQ(wo[0], 1);  // gateway register word_order
}

// Data age is computed at read time from the CAN receive timestamp (plugin.h rx_timestamp_ns).
TEST(RegisterImage, DataAgeIsComputedAtReadTime) {
  RegisterImage img(ImageOptions{});
  img.apply(tpdo(2, 1, 5, kNow - 37'400'000));  // 37.4 ms old
  EXPECT_EQ(slot(img, 2)[11], 37);
  EXPECT_EQ(slot(img, 2, kNow + 1'000'000'000)[11], 1037);  // one second later, same sample
  EXPECT_EQ(data_age_ms(kNow, kNow - 5), 0);                 // clock step backwards: 0, not a wrap
  EXPECT_EQ(data_age_ms(kNow - 70'000'000'000ull, kNow), 0xFFFF);  // saturates
  EXPECT_EQ(data_age_ms(0, kNow), 0xFFFF);                         // never received
}

// With the monotonic receive time given (ABI 2,
// COBRIDGE_VALID_RX_MONOTONIC) the age ignores a step of the wall clock.
TEST(RegisterImage, DataAgeUsesTheMonotonicClockWhenGiven) {
  RegisterImage img(ImageOptions{});
  cobridge_sample s = tpdo(1, 1, 5, kNow);
  s.rx_monotonic_ns = 80'000'000'000ull;
  s.valid |= COBRIDGE_VALID_RX_MONOTONIC;
  img.apply(s);
  std::array<std::uint16_t, kDeviceStride> r{};
  // The wall clock jumped an hour forward; 12 ms passed on the monotonic clock.
  ASSERT_EQ(img.read(device_base(1), r, ReadTime{kNow + 3'600'000'000'000ull, 80'012'000'000ull}, false),
            ReadStatus::kOk);
  EXPECT_EQ(r[11], 12);
}

// Samples without process data (heartbeat, status) do not refresh the data age.
TEST(RegisterImage, HeartbeatDoesNotRefreshDataAge_CiA301_7_2_8_3_2) {
  RegisterImage img(ImageOptions{});
  img.apply(tpdo(0, 1, 5, kNow - 100'000'000));
  cobridge_sample hb{};
  hb.device_index = 0;
  hb.kind = COBRIDGE_SAMPLE_HEARTBEAT;
  hb.sequence = 2;
  hb.rx_timestamp_ns = kNow;
  hb.valid = COBRIDGE_VALID_NMT_STATE;
  hb.nmt_state = COBRIDGE_NMT_OPERATIONAL;
  img.apply(hb);
  const auto r = slot(img, 0);
  EXPECT_EQ(r[11], 100);
  EXPECT_EQ(r[8], 5);  // NMT operational
  EXPECT_EQ(r[9], 1);  // a heartbeat means online
}

// EMCY (CiA 301 §7.2.7.3.1): code and error register of the last EMCY.
TEST(RegisterImage, EmcyStoresLastCodeAndRegister_CiA301_7_2_7) {
  RegisterImage img(ImageOptions{});
  cobridge_sample e{};
  e.device_index = 1;
  e.kind = COBRIDGE_SAMPLE_EMCY;
  e.valid = COBRIDGE_VALID_EMCY;
  e.emcy_code = 0x5530;
  e.emcy_register = 0x81;
  img.apply(e);
  const auto r = slot(img, 1);
  EXPECT_EQ(r[14], 0x5530);
  EXPECT_EQ(r[15], 0x81);
  EXPECT_EQ(r[26], 1);  // present
  EXPECT_EQ(r[11], 0xFFFF);  // no process data yet
}

// Identity from on_device (CiA 301 object 0x1018) and the fields of a full TPDO.
TEST(RegisterImage, DeviceInfoAndAllTpdoFieldsLand_CiA301_7_5_2_8) {
  RegisterImage img(ImageOptions{});
  cobridge_device_info info{};
  info.struct_size = sizeof info;
  info.device_index = 3;
  info.bus_index = 1;
  info.node_id = 42;
  info.change = COBRIDGE_DEVICE_ADDED;
  info.vendor_id = 0x0000012D;
  info.product_code = 0x00010203;
  info.serial = 0xCAFEBABE;
  img.apply(info);
  cobridge_sample s = tpdo(3, 9, 100, kNow);
  s.bus_index = 1;
  s.node_id = 42;
  s.valid |= COBRIDGE_VALID_CAM_STATE | COBRIDGE_VALID_WORK_AREA_STATE | COBRIDGE_VALID_ALARMS |
             COBRIDGE_VALID_WARNINGS | COBRIDGE_VALID_TEMPERATURE | COBRIDGE_VALID_VOLTAGE;
  s.cam_state = 0x05;
  s.work_area_state = 0x02;
  s.alarms = 0x0001;
  s.warnings = 0x0004;
  s.temperature_dC = -55;
  s.voltage_dV = 240;
  img.apply(s);
  const auto r = slot(img, 3);
  EXPECT_EQ(r[4], 0x05);
  EXPECT_EQ(r[5], 0x02);
  EXPECT_EQ(r[6], 0x0001);
  EXPECT_EQ(r[7], 0x0004);
  EXPECT_EQ(static_cast<std::int16_t>(r[16]), -55);
  EXPECT_EQ(r[17], 240);
  EXPECT_EQ(r[18], 42);
  EXPECT_EQ(r[19], 1);
  EXPECT_EQ(r[20], 0xCAFE);
  EXPECT_EQ(r[21], 0xBABE);
  EXPECT_EQ(r[22], 0x0000);
  EXPECT_EQ(r[23], 0x012D);
  EXPECT_EQ(r[25], 0x0203);
}

// Bus block: frames counted per bus, sequence gaps counted as drops (plugin.h `sequence`).
TEST(RegisterImage, BusCountersCountFramesAndSequenceGaps) {
  RegisterImage img(ImageOptions{});
  for (std::uint32_t seq : {1u, 2u, 3u, 7u, 8u}) img.apply(tpdo(0, seq, 0, kNow));  // 3 lost (4, 5, 6)
  cobridge_sample st{};
  st.device_index = 0;
  st.kind = COBRIDGE_SAMPLE_STATUS;
  st.sequence = 9;
  st.valid = COBRIDGE_VALID_STATUS;
  st.online = 1;
  img.apply(st);
  std::array<std::uint16_t, 8> bus{};
  ASSERT_EQ(img.read(bus_base(0), bus, ReadTime{}, false), ReadStatus::kOk);
  EXPECT_EQ(bus[0], static_cast<std::uint16_t>(BusState::kOk));
  EXPECT_EQ(bus[1], 1);
  EXPECT_EQ(bus[2], 1);
  EXPECT_EQ(bus[5], 6);  // frames (u32 low word)
  EXPECT_EQ(bus[7], 3);  // drops
  std::array<std::uint16_t, 16> gw{};
  ASSERT_EQ(img.read(0, gw, ReadTime{}, false), ReadStatus::kOk);
  EXPECT_EQ(gw[0], kMapVersion);
  EXPECT_EQ(gw[6], 1);  // buses
  EXPECT_EQ(gw[7], 1);  // devices
  EXPECT_EQ(gw[8], 1);  // online
  st.online = 0;
  st.sequence = 10;
  img.apply(st);
  ASSERT_EQ(img.read(bus_base(0), bus, ReadTime{}, false), ReadStatus::kOk);
  EXPECT_EQ(bus[0], static_cast<std::uint16_t>(BusState::kDown));
  EXPECT_EQ(bus[7], 3);  // no new drop
}

// docs/modbus.md bus block +3 and controller block: the CAN controller as
// on_bus (plugin.h ABI 5) tells it; ISO 11898-1 states, 65535 = a counter
// the driver does not report.
TEST(RegisterImage, ControllerStateAndCountersFromOnBus) {
  RegisterImage img(ImageOptions{});
  std::array<std::uint16_t, 8> bus{};
  std::array<std::uint16_t, 4> ctl{};
  ASSERT_EQ(img.read(controller_base(1), ctl, ReadTime{}, false), ReadStatus::kOk);
  EXPECT_EQ(ctl[0], kCounterUnknown) << "nothing told yet";
  EXPECT_EQ(ctl[1], kCounterUnknown);
  cobridge_bus_info info{};
  info.struct_size = sizeof info;
  info.bus_index = 1;
  info.state = COBRIDGE_CONTROLLER_ERROR_PASSIVE;
  info.counters_known = 1;
  info.tx_errors = 128;
  info.rx_errors = 3;
  info.restarts = 0x1'0002;
  img.apply(info);
  ASSERT_EQ(img.read(bus_base(1), bus, ReadTime{}, false), ReadStatus::kOk);
  EXPECT_EQ(bus[3], 3) << "error-passive";
  ASSERT_EQ(img.read(controller_base(1), ctl, ReadTime{}, false), ReadStatus::kOk);
  EXPECT_EQ(ctl[0], 128);
  EXPECT_EQ(ctl[1], 3);
  EXPECT_EQ(ctl[2], 1) << "restarts, high word first";
  EXPECT_EQ(ctl[3], 2);
  ASSERT_EQ(img.read(bus_base(0), bus, ReadTime{}, false), ReadStatus::kOk);
  EXPECT_EQ(bus[3], 0) << "another bus stays unknown";
  info.counters_known = 0;  // vcan: the driver reports no counters
  info.state = COBRIDGE_CONTROLLER_BUS_OFF;
  img.apply(info);
  ASSERT_EQ(img.read(controller_base(1), ctl, ReadTime{}, false), ReadStatus::kOk);
  EXPECT_EQ(ctl[0], kCounterUnknown);
  ASSERT_EQ(img.read(bus_base(1), bus, ReadTime{}, false), ReadStatus::kOk);
  EXPECT_EQ(bus[3], 4) << "bus-off";
  info.bus_index = kMaxBuses;  // beyond the map: ignored, not a crash
  img.apply(info);
}

// A device removed (on_device REMOVED) empties its slot.
TEST(RegisterImage, RemovedDeviceEmptiesSlot) {
  RegisterImage img(ImageOptions{});
  img.apply(tpdo(0, 1, 77, kNow));
  cobridge_device_info info{};
  info.struct_size = sizeof info;
  info.device_index = 0;
  info.change = COBRIDGE_DEVICE_REMOVED;
  img.apply(info);
  const auto r = slot(img, 0);
  for (const std::uint16_t v : r) EXPECT_EQ(v, 0);
  std::array<std::uint16_t, 1> count{};
  ASSERT_EQ(img.read(7, count, ReadTime{}, false), ReadStatus::kOk);
  EXPECT_EQ(count[0], 0);
}

// Seqlock: a reader racing one writer never sees a torn slot (position and
// sequence always come from the same sample).
TEST(RegisterImage, ConcurrentReaderNeverSeesTornSlot) {
  RegisterImage img(ImageOptions{});
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (std::uint32_t seq = 1; seq < 300'000; ++seq) {
      img.apply(tpdo(0, seq, static_cast<std::int64_t>(seq) * 65537, kNow));
    }
    done = true;
  });
  std::uint64_t reads = 0;
  std::uint64_t busy = 0;  // a writer hammering one slot non-stop may starve a read (0x04): allowed
  std::uint64_t torn = 0;
  std::uint32_t last = 0;
  while (!done.load()) {
    std::array<std::uint16_t, 14> r{};
    if (img.read(device_base(0), r, ReadTime{kNow, 0}, false) != ReadStatus::kOk) {
      ++busy;
      continue;
    }
    const std::uint32_t pos = (static_cast<std::uint32_t>(r[0]) << 16) | r[1];
    const std::uint32_t seq = (static_cast<std::uint32_t>(r[12]) << 16) | r[13];
    if (pos != static_cast<std::uint32_t>(static_cast<std::uint64_t>(seq) * 65537) || seq < last) ++torn;
    last = seq;
    ++reads;
  }
  writer.join();
  EXPECT_EQ(torn, 0u);
  EXPECT_LT(busy, reads + 1);
  EXPECT_GT(reads, 0u);
}

// Reads beyond the configured slots fail (0x02 in the request layer); samples beyond are counted.
TEST(RegisterImage, SlotsBeyondMaxDevicesAreOutOfRange) {
  ImageOptions o;
  o.device_slots = 2;
  RegisterImage img(o);
  EXPECT_EQ(img.size(), 256u + 64u);
  std::array<std::uint16_t, 1> r{};
  EXPECT_EQ(img.read(device_base(2), r, ReadTime{}, false), ReadStatus::kOutOfRange);
  img.apply(tpdo(5, 1, 0, kNow));
  EXPECT_EQ(img.unmapped_samples(), 1u);
}

}  // namespace
}  // namespace cobridge::modbus
