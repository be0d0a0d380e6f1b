// Request validation and response bytes of the Modbus TCP output.
// References: Modbus Application Protocol Specification V1.1b3 ("MBAP §"),
// Modbus Messaging on TCP/IP Implementation Guide V1.0b ("TCP §").
#include "request.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <initializer_list>
#include <vector>

namespace cobridge::modbus {
namespace {

using Bytes = std::vector<std::uint8_t>;

// MBAP header + PDU with a consistent length field (TCP §3.1.3).
Bytes frame(std::uint16_t tid, std::uint8_t unit, std::initializer_list<std::uint8_t> pdu) {
  Bytes f = {static_cast<std::uint8_t>(tid >> 8), static_cast<std::uint8_t>(tid), 0, 0,
             static_cast<std::uint8_t>((pdu.size() + 1) >> 8), static_cast<std::uint8_t>(pdu.size() + 1), unit};
  f.reserve(f.size() + pdu.size());
  for (std::uint8_t b : pdu) f.push_back(b);  // not insert(): GCC 12 -O2 warns falsely inside it
  return f;
}

class RequestTest : public ::testing::Test {
 protected:
  RequestTest() : image_(options()) {}
  static ImageOptions options() {
    ImageOptions o;
    o.device_slots = 4;  // map: 256 + 4*32 = 384 registers
    return o;
  }
  // Runs the request; returns the response bytes (empty = close).
  Bytes handle(const Bytes& f, RequestPolicy policy = {}) {
    std::vector<std::uint8_t> out(kMaxFrameSize);
    const std::size_t n = handle_request(f, image_, policy, ReadTime{2'000'000'000, 5'000'000'000}, out);
    out.resize(n);
    return out;
  }
  // The exact exception response: same MBAP, length 3, function | 0x80, code (MBAP §7).
  static Bytes exception_bytes(std::uint16_t tid, std::uint8_t unit, std::uint8_t fn, std::uint8_t code) {
    return {static_cast<std::uint8_t>(tid >> 8), static_cast<std::uint8_t>(tid), 0, 0, 0, 3, unit,
            static_cast<std::uint8_t>(fn | 0x80), code};
  }
  RegisterImage image_;
};

// MBAP §6.3 (0x03 Read Holding Registers) response: byte count + values, big-endian.
TEST_F(RequestTest, ReadHoldingRegistersAnswersValues_MBAP_6_3) {
  const Bytes r = handle(frame(0x1234, 0x11, {0x03, 0x00, 0x00, 0x00, 0x02}));
  // map_version = 3, version_major = 0 (no version defined in the test build)
  const Bytes expected = {0x12, 0x34, 0, 0, 0, 7, 0x11, 0x03, 4, 0x00, 0x03, 0x00, 0x00};
  EXPECT_EQ(r, expected);
}

// MBAP §6.4 (0x04 Read Input Registers): same map, same answer shape.
TEST_F(RequestTest, ReadInputRegistersReadsTheSameMap_MBAP_6_4) {
  const Bytes r = handle(frame(1, 1, {0x04, 0x00, 0x0B, 0x00, 0x01}));  // device_stride
  const Bytes expected = {0, 1, 0, 0, 0, 5, 1, 0x04, 2, 0x00, 32};
  EXPECT_EQ(r, expected);
}

// MBAP §7 exception 0x01: function code not supported.
TEST_F(RequestTest, UnknownFunctionIsIllegalFunction_MBAP_7) {
  EXPECT_EQ(handle(frame(7, 1, {0x2B, 0x0E, 0x01, 0x00})), exception_bytes(7, 1, 0x2B, 0x01));
  EXPECT_EQ(handle(frame(8, 1, {0x01, 0x00, 0x00, 0x00, 0x01})), exception_bytes(8, 1, 0x01, 0x01));
  EXPECT_EQ(handle(frame(9, 1, {0x7F})), exception_bytes(9, 1, 0x7F, 0x01));
}

// MBAP §6.3: quantity 1..125 else exception 0x03.
TEST_F(RequestTest, ReadQuantityOutside1To125IsIllegalDataValue_MBAP_6_3) {
  EXPECT_EQ(handle(frame(2, 1, {0x03, 0x00, 0x00, 0x00, 126})), exception_bytes(2, 1, 0x03, 0x03));
  EXPECT_EQ(handle(frame(3, 1, {0x04, 0x00, 0x00, 0x00, 0})), exception_bytes(3, 1, 0x04, 0x03));
  EXPECT_EQ(handle(frame(4, 1, {0x03, 0x00, 0x00, 0xFF, 0xFF})), exception_bytes(4, 1, 0x03, 0x03));
  // 125 is still fine
  const Bytes ok = handle(frame(5, 1, {0x03, 0x00, 0x00, 0x00, 125}));
  ASSERT_EQ(ok.size(), 9u + 250u);
  EXPECT_EQ(ok[8], 250);
}

// MBAP §6.3: start + quantity beyond the map -> exception 0x02.
TEST_F(RequestTest, ReadBeyondTheMapIsIllegalDataAddress_MBAP_6_3) {
  // 384 registers: 380 + 4 = 384 is fine, 380 + 5 is not.
  EXPECT_EQ(handle(frame(1, 1, {0x03, 0x01, 0x7C, 0x00, 0x04})).size(), 9u + 8u);
  EXPECT_EQ(handle(frame(1, 1, {0x03, 0x01, 0x7C, 0x00, 0x05})), exception_bytes(1, 1, 0x03, 0x02));
  EXPECT_EQ(handle(frame(1, 1, {0x03, 0xFF, 0xFF, 0x00, 0x02})), exception_bytes(1, 1, 0x03, 0x02));
}

// MBAP §6.6 / §6.12 with writes disabled (the default): 0x01 illegal function.
TEST_F(RequestTest, WritesDisabledAreIllegalFunction_MBAP_6_6_and_6_12) {
  EXPECT_EQ(handle(frame(1, 1, {0x06, 0x01, 0x00, 0x12, 0x34})), exception_bytes(1, 1, 0x06, 0x01));
  EXPECT_EQ(handle(frame(1, 1, {0x10, 0x01, 0x00, 0x00, 0x01, 0x02, 0x12, 0x34})), exception_bytes(1, 1, 0x10, 0x01));
}

// MBAP §6.12 with writes enabled: quantity / byte count checked (0x03), then
// the address (0x02: without a WriteTarget no register is writable; the
// command registers are tested in command_registers_test.cpp).
TEST_F(RequestTest, WritesEnabledAreValidatedThenRefused_MBAP_6_12) {
  const RequestPolicy p{-1, true, false};
  // byte count 2 but quantity 2 -> 0x03
  EXPECT_EQ(handle(frame(1, 1, {0x10, 0x01, 0x00, 0x00, 0x02, 0x02, 0x12, 0x34}), p), exception_bytes(1, 1, 0x10, 0x03));
  // quantity 0 (byte count 0 consistent) -> 0x03
  EXPECT_EQ(handle(frame(1, 1, {0x10, 0x01, 0x00, 0x00, 0x00, 0x00}), p), exception_bytes(1, 1, 0x10, 0x03));
  // quantity 124 needs 248 value bytes: the frame would be 261 bytes, its
  // length field 255 > 254, so it cannot even be framed -> close
  Bytes big = {0, 1, 0, 0, 0, 255, 1, 0x10, 0x01, 0x00, 0x00, 124, 248};
  big.resize(261, 0);
  EXPECT_TRUE(handle(big, p).empty());
  // consistent request -> 0x02
  EXPECT_EQ(handle(frame(1, 1, {0x10, 0x01, 0x00, 0x00, 0x01, 0x02, 0x12, 0x34}), p), exception_bytes(1, 1, 0x10, 0x02));
  EXPECT_EQ(handle(frame(1, 1, {0x06, 0x01, 0x00, 0x12, 0x34}), p), exception_bytes(1, 1, 0x06, 0x02));
}

// TCP §4.4.1.2 (gateway routing by unit id): another unit -> 0x0A.
TEST_F(RequestTest, OtherUnitIdIsGatewayPathUnavailable_TCP_4_4_1_2) {
  const RequestPolicy p{5, false, false};
  EXPECT_EQ(handle(frame(1, 4, {0x03, 0x00, 0x00, 0x00, 0x01}), p), exception_bytes(1, 4, 0x03, 0x0A));
  EXPECT_EQ(handle(frame(1, 5, {0x03, 0x00, 0x00, 0x00, 0x01}), p).size(), 11u);
}

// MBAP §7 exception 0x0B: the target device (an offline encoder) does not answer.
TEST_F(RequestTest, OfflineDeviceIsGatewayTargetFailedWhenConfigured_MBAP_7) {
  cobridge_sample s{};
  s.device_index = 1;
  s.kind = COBRIDGE_SAMPLE_STATUS;
  s.valid = COBRIDGE_VALID_STATUS;
  s.online = 0;
  image_.apply(s);
  const Bytes req = frame(1, 1, {0x03, 0x01, 0x20, 0x00, 0x04});  // slot 1 at 288
  EXPECT_EQ(handle(req, RequestPolicy{-1, false, true}), exception_bytes(1, 1, 0x03, 0x0B));
  // without offline_exception the registers are served (online = 0)
  EXPECT_EQ(handle(req, RequestPolicy{-1, false, false}).size(), 9u + 8u);
  // the empty slot 0 next to it is not affected
  EXPECT_EQ(handle(frame(1, 1, {0x03, 0x01, 0x00, 0x00, 0x20}), RequestPolicy{-1, false, true}).size(), 9u + 64u);
}

// TCP §3.1.3: protocol identifier 0 = Modbus; anything else closes.
TEST_F(RequestTest, WrongProtocolIdCloses_TCP_3_1_3) {
  Bytes f = frame(1, 1, {0x03, 0x00, 0x00, 0x00, 0x01});
  f[3] = 1;
  EXPECT_TRUE(handle(f).empty());
  EXPECT_EQ(check_frame(std::span(f.data(), 4)).state, FrameState::kInvalid);  // decided after 4 bytes
}

// TCP §3.1.3 / MBAP §4.1: length field 2..254 (PDU 1..253 bytes).
TEST_F(RequestTest, LengthFieldOutside2To254Closes_TCP_3_1_3) {
  const Bytes zero = {0, 1, 0, 0, 0, 1, 1};
  EXPECT_EQ(check_frame(zero).state, FrameState::kInvalid);
  const Bytes big = {0, 1, 0, 0, 0, 255, 1};
  EXPECT_EQ(check_frame(std::span(big.data(), 6)).state, FrameState::kInvalid);  // decided after 6 bytes
  Bytes max = {0, 1, 0, 0, 0, 254, 1, 0x42};
  max.resize(260, 0);
  EXPECT_EQ(check_frame(max).state, FrameState::kComplete);
  EXPECT_EQ(check_frame(max).length, 260u);
  EXPECT_EQ(check_frame(std::span(max.data(), 259)).state, FrameState::kIncomplete);
}

// MBAP §6.3 request is exactly 5 PDU bytes: shorter (truncated) or longer closes.
TEST_F(RequestTest, PduSizeNotMatchingTheFunctionCloses_MBAP_6_3) {
  EXPECT_TRUE(handle(frame(1, 1, {0x03, 0x00, 0x00, 0x00})).empty());
  EXPECT_TRUE(handle(frame(1, 1, {0x03, 0x00, 0x00, 0x00, 0x01, 0x00})).empty());
  EXPECT_TRUE(handle(frame(1, 1, {0x10, 0x01, 0x00, 0x00, 0x01, 0x02, 0x12})).empty());  // byte count says 2, 1 follows
}

// TCP §3.1.3: the transaction id and unit id are echoed; frames are cut by the length field.
TEST_F(RequestTest, PipelinedFramesAreCutByLength_TCP_3_1_3) {
  Bytes two = frame(0xABCD, 9, {0x03, 0x00, 0x00, 0x00, 0x01});
  const Bytes second = frame(0x0001, 9, {0x03, 0x00, 0x00, 0x00, 0x01});
  two.insert(two.end(), second.begin(), second.end());
  const FrameCheck c = check_frame(two);
  ASSERT_EQ(c.state, FrameState::kComplete);
  EXPECT_EQ(c.length, 12u);
  const Bytes r = handle(Bytes(two.begin(), two.begin() + 12));
  ASSERT_GE(r.size(), 7u);
  EXPECT_EQ(r[0], 0xAB);
  EXPECT_EQ(r[1], 0xCD);
  EXPECT_EQ(r[6], 9);
}

}  // namespace
}  // namespace cobridge::modbus
