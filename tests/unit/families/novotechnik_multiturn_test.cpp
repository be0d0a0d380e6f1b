// The Novotechnik multiturn module's EMCY facts (families/novotechnik_multiturn),
// checked against manual E: the E§9.1 code table with its sub-codes, levels
// and position values, and the E§9.1 layout of the CAM and work-area frames.
#include "families/novotechnik_multiturn.hpp"

#include <gtest/gtest.h>

#include <string_view>

#include "families/novotechnik.hpp"

namespace cobridge::families {
namespace {

const EmcyRow* multiturn_row(std::uint16_t code, std::uint8_t b2, std::uint8_t b3) {
  return kNovotechnikMultiturn.emcy->find(code, b2, EmcyDetailBytes{b3, 0, 0, 0, 0});
}

// E§9.1, every row, found through the family's module: (code, byte 2,
// byte 3) -> text, level, position value.
TEST(NovotechnikMultiturnEmcy, E9_1_EveryRowIsInTheModule) {
  ASSERT_NE(kNovotechnikMultiturn.emcy, nullptr);
  EXPECT_EQ(kNovotechnikMultiturn.emcy->source, "E§9.1");
  EXPECT_TRUE(kNovotechnikMultiturn.emcy->byte2_is_subcode);
  using L = EmcyLevel;
  constexpr std::int32_t err = 0x7FFFFFFC;
  constexpr std::int32_t over = 0x7FFFFFF8;
  constexpr auto under = static_cast<std::int32_t>(0x80000008u);
  struct Want {
    std::uint16_t code; std::uint8_t b2; std::uint8_t b3; L level; std::int32_t pos; std::string_view text;
  };
  const Want rows[] = {
      {0x0000, 0, 0, L::hard, 0, "sensor error reset, no error"},
      {0x1000, 1, 0, L::hard, err, "unknown error"},
      {0x3100, 1, 0, L::error, 0, "supply voltage fault"},
      {0x3100, 1, 1, L::warn, 0, "supply voltage overrun (factory-set threshold max exceeded)"},
      {0x3100, 1, 2, L::warn, 0, "supply voltage underrun (factory-set threshold min exceeded)"},
      {0x4210, 1, 1, L::warn, 0, "temperature overrun (factory-set threshold max exceeded)"},
      {0x4210, 1, 2, L::warn, 0, "temperature underrun (factory-set threshold min exceeded)"},
      {0x5000, 1, 0, L::hard, err, "device hardware fault"},
      {0x5000, 0, 0, L::info, 0, "life guarding error"},
      {0x5000, 0, 1, L::info, 0, "maintenance required (operating time limit)"},
      {0x5000, 1, 2, L::hard, err, "hardware ASIC fault"},
      {0x5000, 2, 0, L::hard, 0, "memory lost"},
      {0x5051, 0, 0, L::unspecified, 0, "valid position"},
      {0x5051, 1, 0, L::error, err, "measurement error"},
      {0x5051, 1, 1, L::error, over, "position overflow error, out of range (+); reset via 0x2100"},
      {0x5051, 1, 2, L::error, under, "position underflow error, out of range (-); reset via 0x2100"},
      {0x5051, 2, 1, L::warn, over, "position overflow warning"},
      {0x5051, 2, 2, L::warn, under, "position underflow warning"},
      {0x6000, 1, 0, L::hard, err, "device software fault"},
      {0x6000, 2, 0, L::hard, 0, "insufficient event timer value for the bit rate; TPDO1 sent only partially"},
      {0x8110, 1, 0, L::hard, 0, "CAN controller overflow, CAN overrun; data lost"},
      {0x8110, 2, 0, L::hard, 0, "CAN buffer overflow (CANopen library buffer full); data lost"},
      {0x8120, 0, 0, L::hard, 0, "CAN error passive"},
      {0x8140, 0, 0, L::hard, 0, "CAN recovered from bus-off"},
      {0x9080, 1, 0, L::warn, 0, "encoder CAM state changed"},
      {0x9090, 1, 0, L::warn, 0, "work area state changed"},
  };
  for (const Want& w : rows) {
    SCOPED_TRACE(testing::Message() << std::hex << w.code << "/" << int{w.b2} << "/" << int{w.b3});
    const EmcyRow* r = multiturn_row(w.code, w.b2, w.b3);
    ASSERT_NE(r, nullptr);
    EXPECT_EQ(r->text, w.text);
    EXPECT_EQ(r->level, w.level);
    EXPECT_EQ(r->position, w.pos);
  }
  EXPECT_EQ(kNovotechnikMultiturn.emcy->rows.size(), std::size(rows));
}

// E§9.1: 0x0000 and 0x5051/0/0 ("valid position") announce that the error is gone.
TEST(NovotechnikMultiturnEmcy, E9_1_RecoveryRows) {
  EXPECT_TRUE(multiturn_row(0x0000, 0, 0)->error_reset);
  EXPECT_TRUE(multiturn_row(kMultiturnMeasurementEmcy, 0, 0)->error_reset);
  EXPECT_FALSE(multiturn_row(kMultiturnMeasurementEmcy, 1, 1)->error_reset);
  EXPECT_FALSE(multiturn_row(0x5000, 0, 0)->error_reset);
}

// E§9.1: byte 2 and byte 3 together select the row; others are not in the table.
TEST(NovotechnikMultiturnEmcy, E9_1_UnknownSubCodeIsNotInTheTable) {
  EXPECT_EQ(multiturn_row(0x5000, 3, 0), nullptr);
  EXPECT_EQ(multiturn_row(0x3100, 2, 0), nullptr);
}

// E§9.1 0x9080: byte 4 the changed CAMs 1-4, byte 7 the CAM bits; 0x9090: byte 7
// the state, "coded according to 0x6400" and also listed as 0 valid / 1
// underflow / 2 overflow.
TEST(NovotechnikMultiturnEmcy, E9_1_CamAndWorkAreaLayout) {
  const EmcyDetailBytes cam = multiturn_cam_emcy_bytes(0x03, 0x09);
  EXPECT_EQ(cam, (EmcyDetailBytes{0x00, 0x03, 0x00, 0x00, 0x09}));
  const EmcyDetail c = kNovotechnikMultiturn.emcy->detail(kNovotechnikCamEmcy, cam);
  EXPECT_EQ(c.kind, EmcyDetailKind::cam);
  EXPECT_EQ(c.channel, -1);
  EXPECT_EQ(c.cams, 0x03);
  EXPECT_TRUE(c.changed_cams);
  EXPECT_EQ(c.state, 0x09);

  EXPECT_EQ(multiturn_work_area_emcy_bytes(0x02), (EmcyDetailBytes{0, 0, 0, 0, 0x02}));
  const auto listed = [](std::uint8_t state) {
    return kNovotechnikMultiturn.emcy->detail(kNovotechnikWorkAreaEmcy, multiturn_work_area_emcy_bytes(state))
        .state_listed_as;
  };
  EXPECT_EQ(listed(0), "valid");
  EXPECT_EQ(listed(1), "underflow");
  EXPECT_EQ(listed(2), "overflow");
  EXPECT_EQ(listed(5), "?");
}

// E§9.1: what the position reads while an error is active.
TEST(NovotechnikMultiturnEmcy, E9_1_ErrorPositions) {
  EXPECT_EQ(kMultiturnUnderflowPosition, static_cast<std::int32_t>(0x80000008u));
  const EmcyTable& t = *kNovotechnikMultiturn.emcy;
  EXPECT_NE(t.error_position_meaning(kMultiturnErrorPosition).find("error"), std::string_view::npos);
  EXPECT_NE(t.error_position_meaning(kMultiturnOverflowPosition).find("(+)"), std::string_view::npos);
  EXPECT_NE(t.error_position_meaning(kMultiturnUnderflowPosition).find("(-)"), std::string_view::npos);
  EXPECT_TRUE(t.error_position_meaning(0x7FF0).empty());
}

}  // namespace
}  // namespace cobridge::families
