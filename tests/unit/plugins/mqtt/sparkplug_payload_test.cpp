// PayloadBuilder against the Sparkplug 3.0 payload definition (spec 6.4):
// what it packs decodes with the generated protobuf-c code, the wire tags are
// the spec's field numbers, and the value encodings are the spec's.
#include "sparkplug_payload.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <vector>

namespace cobridge::mqtt {
namespace {

struct Decoded {
  PbPayload* p = nullptr;
  Decoded(const std::uint8_t* data, std::size_t n) : p(org__eclipse__tahu__protobuf__payload__unpack(nullptr, n, data)) {}
  ~Decoded() {
    if (p != nullptr) org__eclipse__tahu__protobuf__payload__free_unpacked(p, nullptr);
  }
};

// Spec 6.4.2: Payload.timestamp = 1 (varint), metrics = 2 (length-delimited),
// seq = 3 (varint). Tags are (field << 3) | wire type.
TEST(SparkplugPayload, Spec642_PayloadFieldNumbersOnTheWire) {
  PayloadBuilder b;
  b.begin(5, std::uint8_t{7});
  std::array<std::uint8_t, 64> buf{};
  const std::size_t n = b.pack(buf);
  ASSERT_EQ(n, 4u);
  EXPECT_EQ(buf[0], 0x08);  // field 1, varint
  EXPECT_EQ(buf[1], 5);
  EXPECT_EQ(buf[2], 0x18);  // field 3, varint
  EXPECT_EQ(buf[3], 7);
}

// Spec 6.4.4: Metric.name = 1, alias = 2, timestamp = 3, datatype = 4,
// long_value = 11.
TEST(SparkplugPayload, Spec644_MetricFieldNumbersOnTheWire) {
  PayloadBuilder b;
  b.begin(1, std::nullopt);
  ASSERT_TRUE(b.add_scalar("a", 2, 3, DataType::kInt64, Scalar{9, 0.0}));
  std::array<std::uint8_t, 64> buf{};
  const std::size_t n = b.pack(buf);
  const std::vector<std::uint8_t> want = {0x08, 1,  0x12, 11, 0x0A, 1, 'a', 0x10, 2,
                                          0x18, 3,  0x20, 4,  0x58, 9};
  ASSERT_EQ(n, want.size());
  EXPECT_EQ(std::vector<std::uint8_t>(buf.begin(), buf.begin() + static_cast<long>(n)), want);
}

TEST(SparkplugPayload, Spec644_ScalarEncodingsByDatatype) {
  PayloadBuilder b;
  b.begin(1000, std::uint8_t{1});
  ASSERT_TRUE(b.add_scalar("i32", 0, 1, DataType::kInt32, Scalar{-2, 0.0}));
  ASSERT_TRUE(b.add_scalar("i64", 0, 1, DataType::kInt64, Scalar{-3, 0.0}));
  ASSERT_TRUE(b.add_scalar("f", 0, 1, DataType::kFloat, Scalar{0, 21.5}));
  ASSERT_TRUE(b.add_scalar("d", 0, 1, DataType::kDouble, Scalar{0, 1.25}));
  ASSERT_TRUE(b.add_scalar("b", 0, 1, DataType::kBoolean, Scalar{1, 0.0}));
  ASSERT_TRUE(b.add_string("s", 0, 1, DataType::kString, "RM9000"));
  ASSERT_TRUE(b.add_null("n", 0, 1, DataType::kUInt16));
  std::array<std::uint8_t, 512> buf{};
  const std::size_t n = b.pack(buf);
  ASSERT_GT(n, 0u);
  Decoded d(buf.data(), n);
  ASSERT_NE(d.p, nullptr);
  ASSERT_EQ(d.p->n_metrics, 7u);
  auto* const* m = d.p->metrics;
  // Signed values as two's complement in the unsigned field.
  EXPECT_EQ(m[0]->value_case, ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__METRIC__VALUE_INT_VALUE);
  EXPECT_EQ(static_cast<std::int32_t>(m[0]->int_value), -2);
  EXPECT_EQ(m[0]->datatype, 3u);
  EXPECT_EQ(m[1]->value_case, ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__METRIC__VALUE_LONG_VALUE);
  EXPECT_EQ(static_cast<std::int64_t>(m[1]->long_value), -3);
  EXPECT_FLOAT_EQ(m[2]->float_value, 21.5f);
  EXPECT_DOUBLE_EQ(m[3]->double_value, 1.25);
  EXPECT_TRUE(m[4]->boolean_value);
  EXPECT_STREQ(m[5]->string_value, "RM9000");
  EXPECT_TRUE(m[6]->has_is_null && m[6]->is_null);
  EXPECT_EQ(m[6]->value_case, ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__METRIC__VALUE__NOT_SET);
  EXPECT_EQ(d.p->seq, 1u);
}

// Spec 6.4.7: a PropertySet's keys[i] names values[i]; each metric its own set.
TEST(SparkplugPayload, Spec647_PropertiesBelongToTheirMetric) {
  PayloadBuilder b;
  b.begin(1, std::uint8_t{0});
  ASSERT_TRUE(b.add_scalar("x", 1, 1, DataType::kDouble, Scalar{0, 1.0}));
  ASSERT_TRUE(b.add_property("engUnit", "deg"));
  ASSERT_TRUE(b.add_scalar("y", 2, 1, DataType::kFloat, Scalar{0, 1.0}));
  ASSERT_TRUE(b.add_property("engUnit", "V"));
  ASSERT_TRUE(b.add_scalar("z", 3, 1, DataType::kInt32, Scalar{1, 0.0}));
  std::array<std::uint8_t, 512> buf{};
  const std::size_t n = b.pack(buf);
  Decoded d(buf.data(), n);
  ASSERT_NE(d.p, nullptr);
  ASSERT_NE(d.p->metrics[0]->properties, nullptr);
  ASSERT_EQ(d.p->metrics[0]->properties->n_keys, 1u);
  EXPECT_STREQ(d.p->metrics[0]->properties->keys[0], "engUnit");
  EXPECT_STREQ(d.p->metrics[0]->properties->values[0]->string_value, "deg");
  EXPECT_EQ(d.p->metrics[0]->properties->values[0]->type, 12u);  // String
  EXPECT_STREQ(d.p->metrics[1]->properties->values[0]->string_value, "V");
  EXPECT_EQ(d.p->metrics[2]->properties, nullptr);
}

TEST(SparkplugPayload, RefusesWhatDoesNotFit) {
  PayloadBuilder b;
  b.begin(1, std::uint8_t{0});
  for (std::size_t i = 0; i < PayloadBuilder::kMaxMetrics; ++i)
    ASSERT_TRUE(b.add_scalar("m", 0, 1, DataType::kInt32, Scalar{1, 0.0}));
  EXPECT_FALSE(b.add_scalar("one too many", 0, 1, DataType::kInt32, Scalar{1, 0.0}));
  std::array<std::uint8_t, 16> small{};
  EXPECT_EQ(b.pack(small), 0u);  // too small: nothing, not a cut payload
}

// Our DataType values are the spec's, and the generated enum agrees.
TEST(SparkplugPayload, Spec6416_DatatypeValues) {
  EXPECT_EQ(static_cast<int>(DataType::kInt8), ORG__ECLIPSE__TAHU__PROTOBUF__DATA_TYPE__Int8);
  EXPECT_EQ(static_cast<int>(DataType::kUInt64), ORG__ECLIPSE__TAHU__PROTOBUF__DATA_TYPE__UInt64);
  EXPECT_EQ(static_cast<int>(DataType::kFloat), 9);
  EXPECT_EQ(static_cast<int>(DataType::kDouble), 10);
  EXPECT_EQ(static_cast<int>(DataType::kBoolean), ORG__ECLIPSE__TAHU__PROTOBUF__DATA_TYPE__Boolean);
  EXPECT_EQ(static_cast<int>(DataType::kString), 12);
  EXPECT_EQ(static_cast<int>(DataType::kDateTime), 13);
  EXPECT_EQ(static_cast<int>(DataType::kText), ORG__ECLIPSE__TAHU__PROTOBUF__DATA_TYPE__Text);
}

}  // namespace
}  // namespace cobridge::mqtt
