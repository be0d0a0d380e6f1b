// The Novotechnik rotary module's EMCY facts (families/novotechnik_rotary),
// checked against manual J: the J§1.8.1 code table, the J§1.8 error
// position, the J§1.8.1 layout of the CAM and work-area frames.
#include "families/novotechnik_rotary.hpp"

#include <gtest/gtest.h>

#include <string_view>

#include "families/novotechnik.hpp"

namespace cobridge::families {
namespace {

// J§1.8.1 prints bytes 3-4 as a little-endian word.
EmcyDetailBytes bytes34(std::uint16_t b34) {
  return {static_cast<std::uint8_t>(b34 & 0xFF), static_cast<std::uint8_t>(b34 >> 8), 0, 0, 0};
}

const EmcyRow* rotary_row(std::uint16_t code, std::uint16_t b34 = 0) {
  return kNovotechnikRotary.emcy->find(code, 1, bytes34(b34));
}

// J§1.8.1, every row of the table, found through the family's module.
TEST(NovotechnikRotaryEmcy, J1_8_1_EveryRowIsInTheModule) {
  ASSERT_NE(kNovotechnikRotary.emcy, nullptr);
  EXPECT_EQ(kNovotechnikRotary.emcy->source, "J§1.8.1");
  EXPECT_FALSE(kNovotechnikRotary.emcy->byte2_is_subcode);  // byte 2 is the CiA error register
  struct Want { std::uint16_t code; std::uint16_t b34; std::string_view text; bool reset; };
  const Want rows[] = {
      {0x0000, 0, "sensor error reset, no error", true},
      {0x5000, 1, "sensor error (internal error bit set)", false},
      {0x6000, 1, "event timer value insufficient for the bit rate; TPDO1 sent only partially", false},
      {0x8110, 1, "CAN controller overflow, CAN overrun; data lost", false},
      {0x8110, 2, "CAN buffer overflow (CANopen library buffer full); data lost", false},
      {0x8120, 0, "CAN error passive", false},
      {0x8140, 0, "CAN recovered from bus-off", false},
      {0x9080, 2, "encoder CAM state changed (coded as 0x6300)", false},
      {0x9090, 1, "work area state changed (coded as 0x6400)", false},
  };
  for (const Want& w : rows) {
    const EmcyRow* r = rotary_row(w.code, w.b34);
    ASSERT_NE(r, nullptr) << w.text;
    EXPECT_EQ(r->text, w.text);
    EXPECT_EQ(r->error_reset, w.reset) << w.text;
    EXPECT_EQ(r->level, EmcyLevel::unspecified) << w.text;  // J defines no levels
    EXPECT_EQ(r->position, 0) << w.text;
  }
  EXPECT_EQ(kNovotechnikRotary.emcy->rows.size(), std::size(rows));
}

// J§1.8.1 0x8110: only bytes 3-4 = 1 or 2 are in the table.
TEST(NovotechnikRotaryEmcy, J1_8_1_CanOverrunNeedsBytes3To4) {
  EXPECT_EQ(rotary_row(0x8110, 3), nullptr);
  EXPECT_EQ(rotary_row(0x8110, 0x0101), nullptr);
  EXPECT_EQ(rotary_row(0x8130), nullptr);  // not a J§1.8.1 code: CiA 301 only
}

// J§1.8.1 0x9080 / 0x9090: channel in bytes 3-4, CAMs in bytes 5-6, state in byte 7.
TEST(NovotechnikRotaryEmcy, J1_8_1_CamAndWorkAreaLayout) {
  const EmcyDetailBytes cam = rotary_cam_emcy_bytes(2, 0x0105, 0x04);
  EXPECT_EQ(cam, (EmcyDetailBytes{0x02, 0x00, 0x05, 0x01, 0x04}));
  const EmcyDetail c = kNovotechnikRotary.emcy->detail(kNovotechnikCamEmcy, cam);
  EXPECT_EQ(c.kind, EmcyDetailKind::cam);
  EXPECT_EQ(c.channel, 2);
  EXPECT_EQ(c.cams, 0x0105);
  EXPECT_FALSE(c.changed_cams);
  EXPECT_EQ(c.state, 0x04);

  const EmcyDetailBytes area = rotary_work_area_emcy_bytes(1, 0x03);
  EXPECT_EQ(area, (EmcyDetailBytes{0x01, 0x00, 0x00, 0x00, 0x03}));
  const EmcyDetail a = kNovotechnikRotary.emcy->detail(kNovotechnikWorkAreaEmcy, area);
  EXPECT_EQ(a.kind, EmcyDetailKind::work_area);
  EXPECT_EQ(a.channel, 1);
  EXPECT_EQ(a.cams, -1);
  EXPECT_EQ(a.state, 0x03);
  EXPECT_TRUE(a.state_listed_as.empty());  // J reads the state as 0x6400 bits only

  EXPECT_EQ(kNovotechnikRotary.emcy->detail(0x5000, cam).kind, EmcyDetailKind::none);
}

// J§1.8: the position reads 0x7FF0 during a position or sensor error.
TEST(NovotechnikRotaryEmcy, J1_8_ErrorPosition) {
  EXPECT_EQ(kRotaryErrorPosition, 0x7FF0);
  EXPECT_EQ(kNovotechnikRotary.emcy->error_position_meaning(0x7FF0), "position or sensor error (J§1.8)");
  EXPECT_TRUE(kNovotechnikRotary.emcy->error_position_meaning(0x3FFF).empty());
}

}  // namespace
}  // namespace cobridge::families
