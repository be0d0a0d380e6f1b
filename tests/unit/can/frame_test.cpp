// can::Frame value semantics (the unit every layer above exchanges).
#include "can/frame.hpp"

#include <gtest/gtest.h>

using cobridge::can::Frame;

TEST(Frame, MakeCopiesPayloadAndLength) {
  const Frame f = Frame::make(0x605, {0x40, 0x18, 0x10, 0x04});
  EXPECT_EQ(f.id, 0x605u);
  EXPECT_EQ(f.len, 4);
  EXPECT_EQ(f.data[0], 0x40);
  EXPECT_EQ(f.data[3], 0x04);
  EXPECT_EQ(f.data[4], 0x00);
}

TEST(Frame, MakeTruncatesAtEightBytes) {
  const Frame f = Frame::make(0x1, {1, 2, 3, 4, 5, 6, 7, 8, 9});
  EXPECT_EQ(f.len, 8);
  EXPECT_EQ(f.data[7], 8);
}

TEST(Frame, EqualityIgnoresTimestampAndUnusedBytes) {
  Frame a = Frame::make(0x181, {1, 2});
  Frame b = a;
  b.timestamp_ns = 12345;
  b.data[5] = 0xAA;  // beyond len: not part of the telegram
  EXPECT_EQ(a, b);
  b.data[1] = 3;
  EXPECT_NE(a, b);
  Frame c = a;
  c.flags = Frame::kFlagRtr;
  EXPECT_NE(a, c);
}
