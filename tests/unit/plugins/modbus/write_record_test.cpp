// WriteRecord: the log line of a Modbus write names the
// client, the unit, the registers, the values and the outcome
// (MBAP §6.6 Write Single Register, §6.12 Write Multiple Registers, §7).
#include "write_record.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

using cobridge::modbus::describe_write;

namespace {

std::vector<std::uint8_t> mbap(std::uint8_t unit, std::vector<std::uint8_t> pdu) {
  pdu.insert(pdu.begin(), {0, 1, 0, 0, 0, static_cast<std::uint8_t>(pdu.size() + 1), unit});
  return pdu;
}

TEST(ModbusWriteRecord, WriteMultipleRegistersApplied_MBAP_6_12) {
  const auto req = mbap(1, {0x10, 0x04, 0x1C, 0x00, 0x02, 0x04, 0xFF, 0xFE, 0x1D, 0xC0});
  const auto resp = mbap(1, {0x10, 0x04, 0x1C, 0x00, 0x02});
  const auto line = describe_write("10.1.2.50:40122", req, resp);
  ASSERT_TRUE(line);
  EXPECT_EQ(*line, "write by 10.1.2.50:40122 (unit 1): registers 1052..1053 = 0xFFFE 0x1DC0: applied");
}

TEST(ModbusWriteRecord, WriteSingleRegisterRefusedNamesTheException_MBAP_6_6) {
  const auto req = mbap(7, {0x06, 0x00, 0x05, 0x00, 0x07});
  const auto resp = mbap(7, {0x86, 0x01});
  const auto line = describe_write("[::1]:5000", req, resp);
  ASSERT_TRUE(line);
  EXPECT_EQ(*line, "write by [::1]:5000 (unit 7): register 5 = 0x0007: refused, exception 0x01");
}

TEST(ModbusWriteRecord, ReadsAndShortFramesAreNotWrites) {
  EXPECT_FALSE(describe_write("a:1", mbap(1, {0x03, 0x00, 0x00, 0x00, 0x02}), mbap(1, {0x03, 0x04, 0, 0, 0, 0})));
  EXPECT_FALSE(describe_write("a:1", mbap(1, {0x10, 0x00}), mbap(1, {0x90, 0x03})));
}

}  // namespace
