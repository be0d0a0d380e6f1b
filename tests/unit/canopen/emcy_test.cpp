#include "canopen/emcy.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace cobridge::canopen {
namespace {

using can::Frame;
using ::testing::HasSubstr;

// A J§1.8.1 row as printed: code | reg (byte 2) | bytes 3-4 | bytes 5-6 | byte 7.
Frame rotary_row(uint8_t node, uint16_t code, uint8_t reg, uint16_t b34, uint16_t b56, uint8_t b7) {
  return Frame::make8(0x80u + node,
                      {static_cast<uint8_t>(code & 0xFF), static_cast<uint8_t>(code >> 8), reg,
                       static_cast<uint8_t>(b34 & 0xFF), static_cast<uint8_t>(b34 >> 8),
                       static_cast<uint8_t>(b56 & 0xFF), static_cast<uint8_t>(b56 >> 8), b7});
}

// An E§9.1 row as printed: code | byte 2 | byte 3 | bytes 7-4 (LE u32).
Frame multiturn_row(uint8_t node, uint16_t code, uint8_t b2, uint8_t b3, uint32_t b74) {
  return Frame::make8(0x80u + node,
                      {static_cast<uint8_t>(code & 0xFF), static_cast<uint8_t>(code >> 8), b2, b3,
                       static_cast<uint8_t>(b74 & 0xFF), static_cast<uint8_t>((b74 >> 8) & 0xFF),
                       static_cast<uint8_t>((b74 >> 16) & 0xFF), static_cast<uint8_t>(b74 >> 24)});
}

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

// J§1.8.1, every row of the table.
TEST(EmcyRotary, J1_8_1_EveryRow) {
  const auto fam = DeviceFamily::novotechnik_rotary;
  struct Row { Frame frame; std::string_view text; bool reset; };
  const Row rows[] = {
      {rotary_row(1, 0x0000, 0, 0, 0, 0), "sensor error reset, no error", true},
      {rotary_row(1, 0x5000, 1, 1, 1, 0), "sensor error (internal error bit set)", false},
      {rotary_row(1, 0x6000, 1, 1, 0, 0),
       "event timer value insufficient for the bit rate; TPDO1 sent only partially", false},
      {rotary_row(1, 0x8110, 1, 1, 0, 0), "CAN controller overflow, CAN overrun; data lost", false},
      {rotary_row(1, 0x8110, 1, 2, 0, 0),
       "CAN buffer overflow (CANopen library buffer full); data lost", false},
      {rotary_row(1, 0x8120, 1, 0, 0, 0), "CAN error passive", false},
      {rotary_row(1, 0x8140, 1, 0, 0, 0), "CAN recovered from bus-off", false},
      {rotary_row(1, 0x9080, 1, 2, 0x0005, 0x01), "encoder CAM state changed (coded as 0x6300)", false},
      {rotary_row(1, 0x9090, 1, 1, 0, 0x02), "work area state changed (coded as 0x6400)", false},
  };
  for (const Row& r : rows) {
    const EmcyInfo info = classify(fam, parsed(r.frame));
    EXPECT_EQ(info.text, r.text);
    EXPECT_TRUE(info.from_manual) << r.text;
    EXPECT_EQ(info.source, "J§1.8.1");
    EXPECT_EQ(info.error_reset, r.reset) << r.text;
    EXPECT_EQ(info.level, EmcyLevel::unspecified);  // J defines no levels
  }
}

// J§1.8.1 0x8110: bytes 3-4 = 1 controller overrun, 2 buffer overflow; other
// values are not in the table and fall back to CiA 301.
TEST(EmcyRotary, J1_8_1_CanOverrunVariants) {
  const EmcyInfo other = classify(DeviceFamily::novotechnik_rotary, parsed(rotary_row(1, 0x8110, 1, 3, 0, 0)));
  EXPECT_FALSE(other.from_manual);
  EXPECT_EQ(other.text, "CAN overrun (objects lost)");
}

// J§1.8.1 0x9080 / 0x9090: channel in bytes 3-4, CAMs in bytes 5-6, state in byte 7.
TEST(EmcyRotary, J1_8_1_CamAndWorkAreaDetails) {
  const Emcy cam = parsed(rotary_row(0x7F, 0x9080, 1, 2, 0x0005, 0x04));
  EXPECT_EQ(rotary_cam_emcy(2, 0x0005, 0x04), cam);
  const std::string d = describe(DeviceFamily::novotechnik_rotary, cam);
  EXPECT_THAT(d, HasSubstr("EMCY 0x9080"));
  EXPECT_THAT(d, HasSubstr("channel 2"));
  EXPECT_THAT(d, HasSubstr("CAMs 0x05"));
  EXPECT_THAT(d, HasSubstr("state 0x04"));
  EXPECT_THAT(d, HasSubstr("J§1.8.1"));
  EXPECT_THAT(d, HasSubstr("error register 0x01 [generic]"));

  const Emcy area = parsed(rotary_row(0x7F, 0x9090, 1, 1, 0, 0x03));
  EXPECT_EQ(rotary_work_area_emcy(1, 0x03), area);
  const std::string a = describe(DeviceFamily::novotechnik_rotary, area);
  EXPECT_THAT(a, HasSubstr("channel 1"));
  EXPECT_THAT(a, HasSubstr("state 0x03 (out of range|overflow)"));
}

// E§9.1, every row: (code, byte 2, byte 3) -> text, level, position value.
TEST(EmcyMultiturn, E9_1_EveryRow) {
  const auto fam = DeviceFamily::novotechnik_multiturn;
  struct Row {
    uint16_t code; uint8_t b2; uint8_t b3; EmcyLevel level; std::optional<int32_t> pos;
    std::string_view text;
  };
  const std::optional<int32_t> none;
  const Row rows[] = {
      {0x0000, 0, 0, EmcyLevel::hard, none, "sensor error reset, no error"},
      {0x1000, 1, 0, EmcyLevel::hard, 0x7FFFFFFC, "unknown error"},
      {0x3100, 1, 0, EmcyLevel::error, none, "supply voltage fault"},
      {0x3100, 1, 1, EmcyLevel::warn, none, "supply voltage overrun (factory-set threshold max exceeded)"},
      {0x3100, 1, 2, EmcyLevel::warn, none, "supply voltage underrun (factory-set threshold min exceeded)"},
      {0x4210, 1, 1, EmcyLevel::warn, none, "temperature overrun (factory-set threshold max exceeded)"},
      {0x4210, 1, 2, EmcyLevel::warn, none, "temperature underrun (factory-set threshold min exceeded)"},
      {0x5000, 1, 0, EmcyLevel::hard, 0x7FFFFFFC, "device hardware fault"},
      {0x5000, 0, 0, EmcyLevel::info, none, "life guarding error"},
      {0x5000, 0, 1, EmcyLevel::info, none, "maintenance required (operating time limit)"},
      {0x5000, 1, 2, EmcyLevel::hard, 0x7FFFFFFC, "hardware ASIC fault"},
      {0x5000, 2, 0, EmcyLevel::hard, none, "memory lost"},
      {0x5051, 0, 0, EmcyLevel::unspecified, none, "valid position"},
      {0x5051, 1, 0, EmcyLevel::error, 0x7FFFFFFC, "measurement error"},
      {0x5051, 1, 1, EmcyLevel::error, 0x7FFFFFF8, "position overflow error, out of range (+); reset via 0x2100"},
      {0x5051, 1, 2, EmcyLevel::error, -2147483640, "position underflow error, out of range (-); reset via 0x2100"},
      {0x5051, 2, 1, EmcyLevel::warn, 0x7FFFFFF8, "position overflow warning"},
      {0x5051, 2, 2, EmcyLevel::warn, -2147483640, "position underflow warning"},
      {0x6000, 1, 0, EmcyLevel::hard, 0x7FFFFFFC, "device software fault"},
      {0x6000, 2, 0, EmcyLevel::hard, none, "insufficient event timer value for the bit rate; TPDO1 sent only partially"},
      {0x8110, 1, 0, EmcyLevel::hard, none, "CAN controller overflow, CAN overrun; data lost"},
      {0x8110, 2, 0, EmcyLevel::hard, none, "CAN buffer overflow (CANopen library buffer full); data lost"},
      {0x8120, 0, 0, EmcyLevel::hard, none, "CAN error passive"},
      {0x8140, 0, 0, EmcyLevel::hard, none, "CAN recovered from bus-off"},
      {0x9080, 1, 0, EmcyLevel::warn, none, "encoder CAM state changed"},
      {0x9090, 1, 0, EmcyLevel::warn, none, "work area state changed"},
  };
  for (const Row& r : rows) {
    const EmcyInfo info = classify(fam, parsed(multiturn_row(0x7F, r.code, r.b2, r.b3, 0)));
    SCOPED_TRACE(testing::Message() << std::hex << r.code << "/" << int{r.b2} << "/" << int{r.b3});
    EXPECT_TRUE(info.from_manual);
    EXPECT_EQ(info.source, "E§9.1");
    EXPECT_EQ(info.text, r.text);
    EXPECT_EQ(info.level, r.level);
    EXPECT_EQ(info.position_value, r.pos);
  }
}

// E§9.1: 0x0000 and 0x5051/0/0 announce that the error is gone.
TEST(EmcyMultiturn, E9_1_RecoveryRows) {
  const auto fam = DeviceFamily::novotechnik_multiturn;
  EXPECT_TRUE(classify(fam, parsed(multiturn_row(1, 0x0000, 0, 0, 0))).error_reset);
  EXPECT_TRUE(classify(fam, parsed(multiturn_row(1, 0x5051, 0, 0, 0))).error_reset);
  EXPECT_FALSE(classify(fam, parsed(multiturn_row(1, 0x5051, 1, 1, 0))).error_reset);
}

// E§9.1: byte 2 is a sub-code, so a row that is not in the table falls back to CiA 301.
TEST(EmcyMultiturn, E9_1_UnknownSubCodeFallsBack) {
  const EmcyInfo info =
      classify(DeviceFamily::novotechnik_multiturn, parsed(multiturn_row(1, 0x5000, 3, 0, 0)));
  EXPECT_FALSE(info.from_manual);
  EXPECT_EQ(info.source, "CiA 301");
  EXPECT_EQ(info.text, "device hardware");
}

// E§9.1 0x9080: byte 4 changed CAMs 1-4, byte 7 CAM status bits.
TEST(EmcyMultiturn, E9_1_CamDetail) {
  const Frame f = Frame::make8(0x81, {0x80, 0x90, 0x01, 0x00, 0x03, 0x00, 0x00, 0x09});
  const Emcy e = parsed(f);
  EXPECT_EQ(multiturn_cam_emcy(0x03, 0x09), e);
  const std::string d = describe(DeviceFamily::novotechnik_multiturn, e);
  EXPECT_THAT(d, HasSubstr("changed CAMs 0x03"));
  EXPECT_THAT(d, HasSubstr("state 0x09"));
  EXPECT_THAT(d, HasSubstr("level Warn"));
  EXPECT_THAT(d, HasSubstr("sub-code 1/0"));
}

// E§9.1 0x9090: state in byte 7, "coded according to 0x6400" and also listed
// as 0 valid / 1 underflow / 2 overflow; describe shows both readings.
TEST(EmcyMultiturn, E9_1_WorkAreaBothReadings) {
  const Frame f = Frame::make8(0x81, {0x90, 0x90, 0x01, 0x00, 0x00, 0x00, 0x00, 0x02});
  const Emcy e = parsed(f);
  EXPECT_EQ(multiturn_work_area_emcy(0x02), e);
  const std::string d = describe(DeviceFamily::novotechnik_multiturn, e);
  EXPECT_THAT(d, HasSubstr("as 0x6400 bits: overflow"));
  EXPECT_THAT(d, HasSubstr("as E§9.1 list: overflow"));
  const std::string one =
      describe(DeviceFamily::novotechnik_multiturn, multiturn_work_area_emcy(0x01));
  EXPECT_THAT(one, HasSubstr("as 0x6400 bits: out of range"));
  EXPECT_THAT(one, HasSubstr("as E§9.1 list: underflow"));
}

// E§9.1 position values appear in the description.
TEST(EmcyMultiturn, E9_1_DescribeShowsPositionValue) {
  const std::string d = describe(DeviceFamily::novotechnik_multiturn,
                                 parsed(multiturn_row(1, 0x5051, 1, 2, 0)));
  EXPECT_THAT(d, HasSubstr("level Error"));
  EXPECT_THAT(d, HasSubstr("position reads 0x80000008"));
}

// F§4 / F§7.3 0x1003: ifm documents no EMCY codes: only CiA 301 texts.
TEST(EmcyIfm, F4_NoCodeTableOnlyCiA301) {
  for (const uint16_t code : {uint16_t{0x8110}, uint16_t{0x8130}, uint16_t{0x5000}}) {
    Emcy e;
    e.error_code = code;
    e.error_register = 0x11;
    const EmcyInfo info = classify(DeviceFamily::ifm_rm, e);
    EXPECT_FALSE(info.from_manual);
    EXPECT_EQ(info.source, "CiA 301");
    EXPECT_EQ(info.text, cia301_text(code));
  }
  Emcy e;
  e.error_code = 0x8130;
  e.error_register = 0x11;
  EXPECT_EQ(describe(DeviceFamily::ifm_rm, e),
            "EMCY 0x8130 life guard error or heartbeat error (CiA 301), error register 0x11 "
            "[generic|communication]");
}

TEST(EmcyGeneric, CiA301_7_2_7_1_GenericFamilyIgnoresVendorTables) {
  const Emcy e = parsed(rotary_row(1, 0x9080, 1, 2, 5, 1));
  EXPECT_EQ(classify(DeviceFamily::generic, e).text, "external error, generic");
  EXPECT_EQ(classify(DeviceFamily::generic, e).source, "CiA 301");
}

// J§1.8 error position 0x7FF0; E§9.1 0x7FFFFFFC / 0x7FFFFFF8 / 0x80000008.
TEST(EmcyPosition, J1_8_And_E9_1_ErrorPositionValues) {
  EXPECT_TRUE(error_position_meaning(DeviceFamily::novotechnik_rotary, 0x7FF0));
  EXPECT_FALSE(error_position_meaning(DeviceFamily::novotechnik_rotary, 0x3FFF));
  const auto mt = DeviceFamily::novotechnik_multiturn;
  EXPECT_THAT(std::string(*error_position_meaning(mt, 0x7FFFFFFC)), HasSubstr("error"));
  EXPECT_THAT(std::string(*error_position_meaning(mt, 0x7FFFFFF8)), HasSubstr("(+)"));
  EXPECT_THAT(std::string(*error_position_meaning(mt, static_cast<int32_t>(-2147483640))),
              HasSubstr("(-)"));
  EXPECT_EQ(kMultiturnUnderflowPosition, static_cast<int32_t>(0x80000008u));
  EXPECT_FALSE(error_position_meaning(mt, 0x7FF0));
  EXPECT_FALSE(error_position_meaning(DeviceFamily::ifm_rm, 0x7FFFFFFC));
}

}  // namespace
}  // namespace cobridge::canopen
