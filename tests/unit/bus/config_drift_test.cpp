// Configuration drift: which client writes touch an object
// the plan sets (CiA 301 §7.4.8.3 0x1017 producer heartbeat time, the TPDO
// objects of §7.5.2.35-36), whether the value differs in the owned bits, and
// what the open records of a device become.
#include "bus/config_drift.hpp"

#include <gtest/gtest.h>

#include <array>

namespace cobridge::bus {
namespace {

PlanStep write_step(const char* label, std::uint16_t index, std::uint8_t sub, std::uint8_t size, std::uint32_t value,
                    std::uint32_t mask = 0xFFFFFFFFu) {
  PlanStep s;
  s.kind = StepKind::write;
  s.label = label;
  s.write.index = index;
  s.write.sub = sub;
  s.write.size = size;
  s.write.value = value;
  s.write.mask = mask;
  return s;
}

ConfigPlan plan() {
  ConfigPlan p;
  p.device = "lift";
  PlanStep nmt;
  nmt.kind = StepKind::nmt;
  p.steps.push_back(nmt);
  PlanStep map;
  map.kind = StepKind::tpdo_mapping;
  map.label = "tpdo1 mapping";
  map.tpdo = 1;
  map.comm_index = 0x1800;
  map.map_index = 0x1A00;
  map.mapping = {0x60040020u, 0x60300110u};
  p.steps.push_back(map);
  p.steps.push_back(write_step("heartbeat_ms", 0x1017, 0, 2, 100));
  // direction (bit 0) and scaling (bit 2) of 0x6000, read-modify-write.
  p.steps.push_back(write_step("direction", 0x6000, 0, 2, 0x0001, 0x0005));
  return p;
}

std::array<std::uint8_t, 2> u16(std::uint16_t v) {
  return {static_cast<std::uint8_t>(v & 0xFF), static_cast<std::uint8_t>(v >> 8)};
}

const WallTime kAt{std::chrono::seconds(1'800'000'000)};

TEST(ConfigDrift, HeartbeatTimeWrittenAwayFromTheConfigurationIsDrift) {
  const auto bytes = u16(9029);
  const DriftCheck c = check_write(plan(), 0x1017, 0, bytes, "tcp 10.0.0.5 (CiA 309-3 gateway)", kAt);
  ASSERT_TRUE(c.configured);
  EXPECT_TRUE(c.differs);
  EXPECT_EQ(c.record.object, "0x1017:00");
  EXPECT_EQ(c.record.name, "heartbeat_ms");
  EXPECT_EQ(c.record.configured, 100u);
  EXPECT_EQ(c.record.value, 9029u);
  EXPECT_EQ(c.record.at, kAt);
  EXPECT_EQ(drift_text(c.record),
            "0x1017:00 (heartbeat_ms) set to 9029 (0x2345) by tcp 10.0.0.5 (CiA 309-3 gateway) "
            "(configured 100 (0x64))");
}

TEST(ConfigDrift, TheConfiguredValueIsNoDrift) {
  const auto bytes = u16(100);
  const DriftCheck c = check_write(plan(), 0x1017, 0, bytes, "cli", kAt);
  EXPECT_TRUE(c.configured);
  EXPECT_FALSE(c.differs);
}

TEST(ConfigDrift, AnObjectThePlanDoesNotSetIsNotConfigured) {
  const std::array<std::uint8_t, 4> bytes{1, 2, 3, 4};
  EXPECT_FALSE(check_write(plan(), 0x6003, 0, bytes, "cli", kAt).configured);
  EXPECT_FALSE(check_write(plan(), 0x1017, 1, bytes, "cli", kAt).configured);
  // Mapping entries beyond the configured two are no setting.
  EXPECT_FALSE(check_write(plan(), 0x1A00, 3, bytes, "cli", kAt).configured);
}

TEST(ConfigDrift, OnlyTheOwnedBitsCount) {
  // Bit 1 (not the plan's) changed, bits 0 and 2 as configured: no drift.
  auto bytes = u16(0x0003);
  EXPECT_FALSE(check_write(plan(), 0x6000, 0, bytes, "cli", kAt).differs);
  // Bit 0 cleared: the configured direction is gone.
  bytes = u16(0x0002);
  const DriftCheck c = check_write(plan(), 0x6000, 0, bytes, "cli", kAt);
  EXPECT_TRUE(c.differs);
  EXPECT_EQ(c.record.owned, 0x0005u);
  EXPECT_NE(drift_text(c.record).find("in bits 0x5"), std::string::npos) << drift_text(c.record);
}

TEST(ConfigDrift, TpdoMappingObjectsAreConfigured) {
  const std::array<std::uint8_t, 1> zero{0};
  const DriftCheck count = check_write(plan(), 0x1A00, 0, zero, "cli", kAt);
  EXPECT_TRUE(count.differs);
  EXPECT_EQ(count.record.configured, 2u);
  const std::array<std::uint8_t, 4> entry{0x20, 0x00, 0x04, 0x60};  // 0x60040020, the configured one
  EXPECT_FALSE(check_write(plan(), 0x1A00, 1, entry, "cli", kAt).differs);
  EXPECT_TRUE(check_write(plan(), 0x1A00, 2, entry, "cli", kAt).differs);
  // COB-ID: another identifier keeps the PDO valid (the id is the device's);
  // bit 31 set disables the configured PDO.
  const std::array<std::uint8_t, 4> other_id{0x85, 0x02, 0x00, 0x00};
  EXPECT_FALSE(check_write(plan(), 0x1800, 1, other_id, "cli", kAt).differs);
  const std::array<std::uint8_t, 4> invalid{0x85, 0x01, 0x00, 0x80};
  EXPECT_TRUE(check_write(plan(), 0x1800, 1, invalid, "cli", kAt).differs);
}

TEST(ConfigDrift, OpenRecordsFollowTheWrites) {
  std::vector<DriftRecord> open;
  auto b9029 = u16(9029);
  auto b500 = u16(500);
  auto b100 = u16(100);
  EXPECT_EQ(apply_check(open, check_write(plan(), 0x1017, 0, b9029, "a", kAt)), DriftChange::opened);
  EXPECT_EQ(apply_check(open, check_write(plan(), 0x1017, 0, b500, "b", kAt)), DriftChange::opened);
  ASSERT_EQ(open.size(), 1u) << "one record per object";
  EXPECT_EQ(open[0].value, 500u);
  EXPECT_EQ(open[0].writer, "b");
  const std::array<std::uint8_t, 4> other{1, 0, 0, 0};
  EXPECT_EQ(apply_check(open, check_write(plan(), 0x6003, 0, other, "c", kAt)), DriftChange::none);
  EXPECT_EQ(apply_check(open, check_write(plan(), 0x1017, 0, b100, "d", kAt)), DriftChange::restored);
  EXPECT_TRUE(open.empty());
  EXPECT_EQ(apply_check(open, check_write(plan(), 0x1017, 0, b100, "d", kAt)), DriftChange::none);
}

// A writer that keeps writing its value (a PLC every second) is one record
// and one log line, not one per write; another value or writer is news.
TEST(ConfigDrift, TheSameWriteAgainRepeatsItsOpenRecord) {
  std::vector<DriftRecord> open;
  auto b200 = u16(200);
  auto b300 = u16(300);
  const DriftCheck first = check_write(plan(), 0x1017, 0, b200, "plc", kAt);
  EXPECT_FALSE(repeats_open_record(open, first));
  (void)apply_check(open, first);
  EXPECT_TRUE(repeats_open_record(open, check_write(plan(), 0x1017, 0, b200, "plc", kAt)));
  EXPECT_FALSE(repeats_open_record(open, check_write(plan(), 0x1017, 0, b300, "plc", kAt)));
  EXPECT_FALSE(repeats_open_record(open, check_write(plan(), 0x1017, 0, b200, "cli", kAt)));
  EXPECT_FALSE(repeats_open_record(open, check_write(plan(), 0x6003, 0, b200, "plc", kAt))) << "not configured";
  ASSERT_NE(open_record(open, 0x1017, 0), nullptr);
  EXPECT_EQ(open_record(open, 0x1017, 0)->value, 200u);
  EXPECT_EQ(open_record(open, 0x1017, 1), nullptr);
}

}  // namespace
}  // namespace cobridge::bus
