#include "canopen/emcy.hpp"

#include <gtest/gtest.h>

namespace cobridge::canopen {
namespace {

using can::Frame;

Emcy parsed(const Frame& f) {
  const EmcyParse p = parse_emcy(f);
  EXPECT_TRUE(p.ok()) << to_string(p.error);
  return p.emcy;
}

// CiA 301 §7.2.7.3.1: 8 bytes, code LE in bytes 0-1, error register in byte 2.
TEST(Emcy, CiA301_7_2_7_3_1_Decode) {
  const EmcyParse p = parse_emcy(Frame::make8(0x8A, {0x10, 0x81, 0x11, 1, 2, 3, 4, 5}));
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(p.node, 10);
  EXPECT_EQ(p.emcy.error_code, 0x8110);
  EXPECT_EQ(p.emcy.error_register, 0x11);
  EXPECT_EQ(p.emcy.manufacturer, (std::array<uint8_t, 5>{1, 2, 3, 4, 5}));
}

// CiA 301 §7.2.7.3.1 / J§1.8.1 / E§9.1 "DLC 8": other lengths are rejected.
TEST(Emcy, CiA301_7_2_7_3_1_RejectsWrongLengthAndIds) {
  EXPECT_EQ(parse_emcy(Frame::make(0x81, {0x00, 0x50, 0x01, 0, 0, 0, 0})).error,
            EmcyFrameError::wrong_length);
  EXPECT_EQ(parse_emcy(Frame::make(0x81, {})).error, EmcyFrameError::wrong_length);
  // 0x80 itself is SYNC, 0x100 is beyond 0x80 + 127.
  EXPECT_EQ(parse_emcy(Frame::make8(0x80, {})).error, EmcyFrameError::wrong_cob_id);
  EXPECT_EQ(parse_emcy(Frame::make8(0x100, {})).error, EmcyFrameError::wrong_cob_id);
  Frame rtr = Frame::make8(0x81, {});
  rtr.flags = Frame::kFlagRtr;
  EXPECT_EQ(parse_emcy(rtr).error, EmcyFrameError::remote_request);
  // F§7.3 0x1014 is rw: decode_emcy skips the COB-ID check.
  EXPECT_TRUE(decode_emcy(Frame::make8(0x123, {})).ok());
  EXPECT_EQ(decode_emcy(Frame::make8(0x123, {})).node, 0);
}

// CiA 301 §7.2.7.3.1: the encoder writes the same layout back.
TEST(Emcy, CiA301_7_2_7_3_1_EncodeRoundTrip) {
  Emcy e;
  e.error_code = 0x9080;
  e.error_register = 0x01;
  e.manufacturer = {0x02, 0x00, 0x05, 0x00, 0x01};
  const Frame f = make_emcy(0x7F, e);
  EXPECT_EQ(f, Frame::make8(0xFF, {0x80, 0x90, 0x01, 0x02, 0x00, 0x05, 0x00, 0x01}));
  EXPECT_EQ(parsed(f), e);
  EXPECT_EQ(make_emcy_on(0x1F0, e).id, 0x1F0u);
}

// CiA 301 §7.2.7.1 table of emergency error codes.
TEST(Emcy, CiA301_7_2_7_1_CodeTexts) {
  EXPECT_EQ(cia301_text(0x0000), "error reset or no error");
  EXPECT_EQ(cia301_text(0x1000), "generic error");
  EXPECT_EQ(cia301_text(0x2310), "current, device output side");
  EXPECT_EQ(cia301_text(0x2000), "current, generic");
  EXPECT_EQ(cia301_text(0x3100), "mains voltage");
  EXPECT_EQ(cia301_text(0x4210), "device temperature");
  EXPECT_EQ(cia301_text(0x5000), "device hardware");
  EXPECT_EQ(cia301_text(0x5051), "device hardware");
  EXPECT_EQ(cia301_text(0x6100), "internal software");
  EXPECT_EQ(cia301_text(0x7000), "additional modules");
  EXPECT_EQ(cia301_text(0x8000), "monitoring, generic");
  EXPECT_EQ(cia301_text(0x8110), "CAN overrun (objects lost)");
  EXPECT_EQ(cia301_text(0x8120), "CAN in error passive mode");
  EXPECT_EQ(cia301_text(0x8130), "life guard error or heartbeat error");
  EXPECT_EQ(cia301_text(0x8140), "recovered from bus off");
  EXPECT_EQ(cia301_text(0x8150), "CAN-ID collision");
  EXPECT_EQ(cia301_text(0x8200), "protocol error, generic");
  EXPECT_EQ(cia301_text(0x8210), "PDO not processed due to length error");
  EXPECT_EQ(cia301_text(0x8220), "PDO length exceeded");
  EXPECT_EQ(cia301_text(0x9000), "external error, generic");
  EXPECT_EQ(cia301_text(0x9080), "external error, generic");
  EXPECT_EQ(cia301_text(0xF001), "additional functions, generic");
  EXPECT_EQ(cia301_text(0xFF42), "device specific, generic");
  EXPECT_EQ(cia301_text(0xA000), "reserved");
}

// CiA 301 §7.5.2.2 object 0x1001 bits.
TEST(Emcy, CiA301_7_5_2_2_ErrorRegisterBits) {
  EXPECT_EQ(error_register_text(0x00), "none");
  EXPECT_EQ(error_register_text(0x01), "generic");
  EXPECT_EQ(error_register_text(0x11), "generic|communication");
  EXPECT_EQ(error_register_text(0xFF),
            "generic|current|voltage|temperature|communication|device profile specific|"
            "reserved|manufacturer specific");
}

// CiA 406 object 0x6400: bit 0 out of range, bit 1 overflow, bit 2 underflow.
TEST(Emcy, CiA406_WorkAreaStateBits) {
  EXPECT_EQ(work_area_state_text(0x00), "inside");
  EXPECT_EQ(work_area_state_text(0x03), "out of range|overflow");
  EXPECT_EQ(work_area_state_text(0x05), "out of range|underflow");
}

}  // namespace
}  // namespace cobridge::canopen
