// The command registers of the Modbus output (docs/modbus.md "Writes"):
// what a write submits to the daemon (plugin ABI 2 submit_command), which
// writes are refused with which exception (Modbus Application Protocol
// V1.1b3 §7), and how the outcome (a COMMAND sample) shows in
// command_status, never overwriting a newer command's state.
#include "command_registers.hpp"

#include <gtest/gtest.h>

#include <array>
#include <vector>

namespace cobridge::modbus {
namespace {

constexpr std::uint64_t kSecond = 1'000'000'000u;

struct Daemon {
  std::vector<cobridge_command> seen;
  int answer = COBRIDGE_COMMAND_OK;
  CommandRegisters::Submit submit() {
    return [this](const cobridge_command& c) {
      seen.push_back(c);
      return answer;
    };
  }
};

void announce(RegisterImage& img, std::uint16_t device, bool online) {
  cobridge_sample s{};
  s.device_index = device;
  s.node_id = static_cast<std::uint8_t>(device + 1);
  s.kind = COBRIDGE_SAMPLE_STATUS;
  s.sequence = 1;
  s.valid = COBRIDGE_VALID_STATUS;
  s.online = online ? 1 : 0;
  img.apply(s);
}

cobridge_sample outcome(std::uint16_t device, std::uint32_t tag, int status) {
  cobridge_sample s{};
  s.device_index = device;
  s.kind = COBRIDGE_SAMPLE_COMMAND;
  s.valid = COBRIDGE_VALID_COMMAND;
  s.command_tag = tag;
  s.command_status = static_cast<std::uint8_t>(status);
  return s;
}

std::uint16_t reg(std::uint16_t slot, std::uint16_t offset) {
  return static_cast<std::uint16_t>(device_base(slot) + offset);
}

struct Fixture : ::testing::Test {
  explicit Fixture(WordOrder order = WordOrder::kBig) : img(options(order)), regs(img, daemon.submit()) {
    announce(img, 0, true);
    announce(img, 1, false);
    img.attach(&regs);
  }
  static ImageOptions options(WordOrder order) {
    ImageOptions o;
    o.device_slots = 4;
    o.word_order = order;
    o.writes_enabled = true;
    return o;
  }
  std::array<std::uint16_t, 4> command_block(std::uint16_t slot) {
    std::array<std::uint16_t, 4> r{};
    EXPECT_EQ(img.read(reg(slot, 28), r, ReadTime{1, 1}, false), ReadStatus::kOk);
    return r;
  }
  ExceptionCode write(std::uint16_t address, std::vector<std::uint16_t> values, std::uint64_t mono = kSecond) {
    return regs.write(address, values, ReadTime{1, mono});
  }
  Daemon daemon;
  RegisterImage img;
  CommandRegisters regs;
};

using CommandRegistersTest = Fixture;

// +28..29 value (big word order: high word first), +30 command: one 0x10
// request submits a preset of the signed 32-bit value to the slot's device.
TEST_F(CommandRegistersTest, PresetSubmitsTheSignedValueAndShowsPending) {
  EXPECT_EQ(write(reg(0, 28), {0xFFFE, 0x1DC0, 1}), ExceptionCode::kNone);  // -123456
  ASSERT_EQ(daemon.seen.size(), 1u);
  const cobridge_command& c = daemon.seen[0];
  EXPECT_EQ(c.struct_size, sizeof(cobridge_command));
  EXPECT_EQ(c.device_index, 0);
  EXPECT_EQ(c.kind, COBRIDGE_COMMAND_PRESET);
  EXPECT_EQ(c.value, -123456);
  EXPECT_EQ(command_block(0), (std::array<std::uint16_t, 4>{0xFFFE, 0x1DC0, 1, kCommandPending}));

  regs.on_sample(outcome(0, c.tag, COBRIDGE_COMMAND_OK));
  EXPECT_EQ(command_block(0)[3], kCommandDone);
}

// A refusal reported later reads 2 + the cobridge_command_status code.
TEST_F(CommandRegistersTest, OutcomeCodesAreTwoPlusTheStatus) {
  ASSERT_EQ(write(reg(0, 30), {3}), ExceptionCode::kNone);
  regs.on_sample(outcome(0, daemon.seen.back().tag, COBRIDGE_COMMAND_REFUSED));
  EXPECT_EQ(command_block(0)[3], 8);
  EXPECT_EQ(command_block(0)[2], COBRIDGE_COMMAND_STORE);
  EXPECT_EQ(daemon.seen.back().value, 0);  // only a preset carries the value
}

// A late outcome of an older command never overwrites the newer one.
TEST_F(CommandRegistersTest, OutcomeOfAnOlderTagIsIgnored) {
  ASSERT_EQ(write(reg(0, 30), {2}), ExceptionCode::kNone);
  const std::uint32_t first = daemon.seen.back().tag;
  regs.on_sample(outcome(0, first, COBRIDGE_COMMAND_OK));
  ASSERT_EQ(write(reg(0, 30), {3}), ExceptionCode::kNone);
  regs.on_sample(outcome(0, first, COBRIDGE_COMMAND_TIMEOUT));  // a duplicate of the old one
  EXPECT_EQ(command_block(0)[3], kCommandPending);
  regs.on_sample(outcome(0, daemon.seen.back().tag, COBRIDGE_COMMAND_OK));
  EXPECT_EQ(command_block(0)[3], kCommandDone);
}

// §7 0x06 Server Device Busy while the slot's command is pending, for at
// most kPendingTimeoutNs (an outcome lost on the way must not lock the slot).
TEST_F(CommandRegistersTest, PendingCommandMakesTheNextOneBusyUntilTheTimeout) {
  ASSERT_EQ(write(reg(0, 30), {2}, kSecond), ExceptionCode::kNone);
  EXPECT_EQ(write(reg(0, 30), {2}, 2 * kSecond), ExceptionCode::kServerDeviceBusy);
  EXPECT_EQ(daemon.seen.size(), 1u);
  EXPECT_EQ(write(reg(0, 30), {2}, kSecond + CommandRegisters::kPendingTimeoutNs), ExceptionCode::kNone);
  EXPECT_EQ(daemon.seen.size(), 2u);
}

// Only +28..+30 of one slot are writable (§7 0x02), only codes 1..3 (0x03);
// nothing changes on an exception.
TEST_F(CommandRegistersTest, OnlyTheCommandRegistersAreWritable) {
  EXPECT_EQ(write(reg(0, 27), {1}), ExceptionCode::kIllegalDataAddress);
  EXPECT_EQ(write(reg(0, 31), {1}), ExceptionCode::kIllegalDataAddress);
  EXPECT_EQ(write(reg(0, 29), {1, 1, 0}), ExceptionCode::kIllegalDataAddress);
  EXPECT_EQ(write(reg(0, 30), {0, 0, 0}), ExceptionCode::kIllegalDataAddress);  // runs into slot 1
  EXPECT_EQ(write(10, {1}), ExceptionCode::kIllegalDataAddress);                 // bus block
  EXPECT_EQ(write(reg(0, 28), {7, 7, 4}), ExceptionCode::kIllegalDataValue);
  EXPECT_EQ(write(reg(0, 30), {0}), ExceptionCode::kIllegalDataValue);
  EXPECT_TRUE(daemon.seen.empty());
  EXPECT_EQ(command_block(0), (std::array<std::uint16_t, 4>{0, 0, 0, kCommandNone}));
}

// The value alone is kept (no command); §7 0x0B for a command to an offline
// device or an empty slot.
TEST_F(CommandRegistersTest, ValueAloneIsKeptAndAbsentDevicesAre0x0B) {
  EXPECT_EQ(write(reg(0, 29), {0x0042}), ExceptionCode::kNone);
  EXPECT_EQ(command_block(0)[1], 0x0042);
  EXPECT_EQ(write(reg(1, 30), {1}), ExceptionCode::kGatewayTargetFailed);  // offline
  EXPECT_EQ(write(reg(2, 30), {1}), ExceptionCode::kGatewayTargetFailed);  // empty slot
  EXPECT_EQ(write(reg(2, 28), {1}), ExceptionCode::kGatewayTargetFailed);
  EXPECT_TRUE(daemon.seen.empty());
}

// A refusal from submit_command itself: the Modbus answer and the status.
TEST_F(CommandRegistersTest, ImmediateRefusalsMapToExceptions) {
  daemon.answer = COBRIDGE_COMMAND_BUSY;
  EXPECT_EQ(write(reg(0, 30), {2}), ExceptionCode::kServerDeviceBusy);
  EXPECT_EQ(command_block(0)[3], 2 + COBRIDGE_COMMAND_BUSY);
  daemon.answer = COBRIDGE_COMMAND_OFFLINE;
  EXPECT_EQ(write(reg(0, 30), {2}), ExceptionCode::kGatewayTargetFailed);
  daemon.answer = COBRIDGE_COMMAND_UNSUPPORTED;
  EXPECT_EQ(write(reg(0, 30), {2}), ExceptionCode::kServerDeviceFailure);
  EXPECT_EQ(command_block(0)[3], 2 + COBRIDGE_COMMAND_UNSUPPORTED);
}

// An empty slot reads all zeros, the command registers included.
TEST_F(CommandRegistersTest, EmptySlotReadsZeros) { EXPECT_EQ(command_block(3), (std::array<std::uint16_t, 4>{})); }

struct LittleFixture : Fixture {
  LittleFixture() : Fixture(WordOrder::kLittle) {}
};

// word_order = "little": +28 holds the low word.
TEST_F(LittleFixture, LittleWordOrderTakesTheLowWordFirst) {
  ASSERT_EQ(write(reg(0, 28), {0x1DC0, 0xFFFE, 1}), ExceptionCode::kNone);
  ASSERT_EQ(daemon.seen.size(), 1u);
  EXPECT_EQ(daemon.seen[0].value, -123456);
}

}  // namespace
}  // namespace cobridge::modbus
