// device/emcy_meaning: an EMCY read with the family module's table first
// (J§1.8.1, E§9.1) and the CiA 301 table otherwise (§7.2.7.1), and the log
// line built from both. The rows themselves are checked against the manuals
// in tests/unit/families; here, how they combine.
#include "device/emcy_meaning.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "families/ifm_rm.hpp"
#include "families/novotechnik.hpp"
#include "families/novotechnik_multiturn.hpp"
#include "families/novotechnik_rotary.hpp"

namespace cobridge::device {
namespace {

using ::testing::HasSubstr;
namespace fam = families;
const fam::Family* const kRotary = &fam::kNovotechnikRotary;
const fam::Family* const kMultiturn = &fam::kNovotechnikMultiturn;
const fam::Family* const kIfm = &fam::kIfmRm;

canopen::Emcy emcy(std::uint16_t code, std::uint8_t byte2, fam::EmcyDetailBytes rest = {}) {
  return canopen::Emcy{code, byte2, rest};
}

// J§1.8.1: a row of the rotary module answers, with its section.
TEST(EmcyMeaning, J1_8_1_RotaryRowFromTheModule) {
  const EmcyInfo info = classify_emcy(kRotary, emcy(0x5000, 1));
  EXPECT_TRUE(info.from_manual);
  EXPECT_EQ(info.source, "J§1.8.1");
  EXPECT_EQ(info.text, "sensor error (internal error bit set)");
  EXPECT_EQ(info.level, EmcyLevel::unspecified);
  EXPECT_FALSE(info.position_value);
  EXPECT_TRUE(classify_emcy(kRotary, emcy(0x0000, 0)).error_reset);
}

// J§1.8.1 0x8110 with bytes 3-4 not 1 or 2 is no row: CiA 301 §7.2.7.1 answers.
TEST(EmcyMeaning, J1_8_1_UnlistedBytesFallBackToCiA301) {
  const EmcyInfo other = classify_emcy(kRotary, emcy(0x8110, 1, {3, 0, 0, 0, 0}));
  EXPECT_FALSE(other.from_manual);
  EXPECT_EQ(other.source, "CiA 301");
  EXPECT_EQ(other.text, "CAN overrun (objects lost)");
}

// J§1.8.1 0x9080 / 0x9090: the detail bytes decoded in the log line.
TEST(EmcyMeaning, J1_8_1_DescribeCamAndWorkArea) {
  const canopen::Emcy cam = emcy(fam::kNovotechnikCamEmcy, 1, fam::rotary_cam_emcy_bytes(2, 0x0005, 0x04));
  EXPECT_EQ(describe_emcy(kRotary, cam),
            "EMCY 0x9080 encoder CAM state changed (coded as 0x6300) (Novotechnik rotary CANopen manual §1.8.1), channel 2, CAMs 0x05, "
            "state 0x04, error register 0x01 [generic]");
  const canopen::Emcy area = emcy(fam::kNovotechnikWorkAreaEmcy, 1, fam::rotary_work_area_emcy_bytes(1, 0x03));
  EXPECT_THAT(describe_emcy(kRotary, area), HasSubstr("channel 1, state 0x03 (out of range|overflow)"));
}

// E§9.1: level and position value of the row; byte 2 shown as a sub-code.
TEST(EmcyMeaning, E9_1_LevelPositionAndSubCode) {
  const EmcyInfo info = classify_emcy(kMultiturn, emcy(fam::kMultiturnMeasurementEmcy, 1, {2, 0, 0, 0, 0}));
  EXPECT_EQ(info.source, "E§9.1");
  EXPECT_EQ(info.level, EmcyLevel::error);
  EXPECT_EQ(info.position_value, fam::kMultiturnUnderflowPosition);
  const std::string d = describe_emcy(kMultiturn, emcy(fam::kMultiturnMeasurementEmcy, 1, {2, 0, 0, 0, 0}));
  EXPECT_THAT(d, HasSubstr("level Error"));
  EXPECT_THAT(d, HasSubstr("sub-code 1/2"));
  EXPECT_THAT(d, HasSubstr("position reads 0x80000008"));
  EXPECT_THAT(d, ::testing::Not(HasSubstr("error register")));
}

// E§9.1: a sub-code not in the table falls back to CiA 301, and byte 2 is
// then read as the CiA error register.
TEST(EmcyMeaning, E9_1_UnknownSubCodeFallsBack) {
  const canopen::Emcy e = emcy(0x5000, 3);
  const EmcyInfo info = classify_emcy(kMultiturn, e);
  EXPECT_FALSE(info.from_manual);
  EXPECT_EQ(info.source, "CiA 301");
  EXPECT_EQ(info.text, "device hardware");
  EXPECT_THAT(describe_emcy(kMultiturn, e), HasSubstr("error register 0x03 [generic|current]"));
}

// E§9.1 0x9080 / 0x9090: changed CAMs; the work-area state read both ways.
TEST(EmcyMeaning, E9_1_DescribeCamAndBothWorkAreaReadings) {
  const std::string cam =
      describe_emcy(kMultiturn, emcy(fam::kNovotechnikCamEmcy, 1, fam::multiturn_cam_emcy_bytes(3, 9)));
  EXPECT_THAT(cam, HasSubstr("(Novotechnik multiturn MZ1/MC1/MB1 CANopen manual §9.1), level Warn, changed CAMs 0x03, state 0x09, sub-code 1/0"));
  const std::string area =
      describe_emcy(kMultiturn, emcy(fam::kNovotechnikWorkAreaEmcy, 1, fam::multiturn_work_area_emcy_bytes(1)));
  EXPECT_THAT(area, HasSubstr("state 0x01 (as 0x6400 bits: out of range; as Novotechnik multiturn MZ1/MC1/MB1 CANopen manual §9.1 list: underflow)"));
}

// F§4: ifm has no table; CiA 301 §7.2.7.1 texts with the error register bits.
TEST(EmcyMeaning, F4_IfmGivesCiA301Only) {
  const canopen::Emcy e = emcy(0x8130, 0x11);
  EXPECT_EQ(classify_emcy(kIfm, e).text, canopen::cia301_text(0x8130));
  EXPECT_EQ(describe_emcy(kIfm, e),
            "EMCY 0x8130 life guard error or heartbeat error (CiA 301), error register 0x11 "
            "[generic|communication]");
}

// CiA 301 §7.2.7.1: a device no family knows gets no vendor text.
TEST(EmcyMeaning, CiA301_7_2_7_1_UnknownFamilyIgnoresVendorTables) {
  const EmcyInfo info = classify_emcy(nullptr, emcy(fam::kNovotechnikCamEmcy, 1, {2, 0, 5, 0, 1}));
  EXPECT_EQ(info.text, "external error, generic");
  EXPECT_EQ(info.source, "CiA 301");
  EXPECT_TRUE(classify_emcy(nullptr, emcy(0x0000, 0)).error_reset);
}

// J§1.8 0x7FF0; E§9.1 0x7FFFFFFC / 0x7FFFFFF8 / 0x80000008; F names none.
TEST(EmcyMeaning, J1_8_And_E9_1_ErrorPositionValues) {
  EXPECT_TRUE(error_position_meaning(kRotary, 0x7FF0));
  EXPECT_FALSE(error_position_meaning(kRotary, 0x3FFF));
  EXPECT_THAT(std::string(*error_position_meaning(kMultiturn, 0x7FFFFFF8)), HasSubstr("(+)"));
  EXPECT_FALSE(error_position_meaning(kMultiturn, 0x7FF0));
  EXPECT_FALSE(error_position_meaning(kIfm, 0x7FFFFFFC));
  EXPECT_FALSE(error_position_meaning(nullptr, 0x7FF0));
}

TEST(EmcyMeaning, E9_1_LevelNames) {
  EXPECT_EQ(to_string(EmcyLevel::info), "Info");
  EXPECT_EQ(to_string(EmcyLevel::hard), "Hard");
}

}  // namespace
// People read the EMCY text (log, status, web page): each citation names
// the manual, not its key.
TEST(EmcyMeaning, CitationsNameTheManual) {
  EXPECT_EQ(families::cite_manuals("position or sensor error (J\u00a71.8)"),
            "position or sensor error (Novotechnik rotary CANopen manual \u00a71.8)");
  EXPECT_EQ(families::cite_manuals("synchronous only (J\u00a71.3.1 / E\u00a74.1 0x1801/2), F\u00a77.5"),
            "synchronous only (Novotechnik rotary CANopen manual \u00a71.3.1 / Novotechnik multiturn MZ1/MC1/MB1 "
            "CANopen manual \u00a74.1 0x1801/2), ifm RM8xxx/RM9xxx operating instructions \u00a77.5");
  EXPECT_EQ(families::cite_manuals("CiA 301 \u00a77.2.7"), "CiA 301 \u00a77.2.7") << "not a manual key";
  EXPECT_EQ(families::cite_manuals("X\u00a71"), "X\u00a71");
}

}  // namespace cobridge::device
