// EmcyTable (families/emcy_table): how a family's rows match a frame
// (CiA 301 §7.2.7: code, then the bytes a manual's row names).
#include "families/emcy_table.hpp"

#include <gtest/gtest.h>

#include <array>

namespace cobridge::families {
namespace {

constexpr std::array<EmcyRow, 3> kRows{{
    {.code = 0x8110, .byte3 = 1, .byte4 = 0, .text = "overrun"},
    {.code = 0x8110, .text = "any 0x8110"},
    {.code = 0x5000, .byte2 = 2, .text = "byte 2 is 2"},
}};
constexpr std::array<ErrorPosition, 1> kPositions{{{0x7FF0, "sentinel"}}};
constexpr EmcyTable kTable{.source = "test", .rows = kRows, .error_positions = kPositions};

TEST(EmcyTable, RowMatchesTheBytesItNamesAndLeavesTheOthersFree) {
  EXPECT_EQ(kTable.find(0x8110, 9, {1, 0, 7, 7, 7})->text, "overrun");
  EXPECT_EQ(kTable.find(0x8110, 9, {1, 1, 0, 0, 0})->text, "any 0x8110");  // byte 4 differs: next row
  EXPECT_EQ(kTable.find(0x5000, 2, {})->text, "byte 2 is 2");
  EXPECT_EQ(kTable.find(0x5000, 1, {}), nullptr);
  EXPECT_EQ(kTable.find(0x6000, 0, {}), nullptr);
}

TEST(EmcyTable, ErrorPositionMeaning) {
  EXPECT_EQ(kTable.error_position_meaning(0x7FF0), "sentinel");
  EXPECT_TRUE(kTable.error_position_meaning(0).empty());
}

TEST(EmcyTable, EmptyTableFindsNothing) {
  constexpr EmcyTable empty{};
  EXPECT_EQ(empty.find(0x0000, 0, {}), nullptr);
  EXPECT_TRUE(empty.error_position_meaning(0x7FF0).empty());
}

}  // namespace
}  // namespace cobridge::families
