// base/json_writer: the one encoder of the JSON the daemon and the CLI write
// (RFC 8259): commas and nesting, string escapes (§7), numbers (§6: no NaN
// or infinity, so those are null), and embedded documents.
#include "base/json_writer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

namespace {

using cobridge::JsonWriter;

TEST(JsonWriter, Rfc8259_CommasSeparateMembersAndElementsAtEveryDepth) {
  JsonWriter w;
  w.begin_object().field("a", 1).key("b").begin_array().value(1).value(2).begin_object().end_object().end_array();
  w.key("c").begin_object().field("d", true).field("e", false).end_object().key("f").null();
  EXPECT_EQ(w.end_object().take(), R"({"a":1,"b":[1,2,{}],"c":{"d":true,"e":false},"f":null})");
}

TEST(JsonWriter, EmptyContainersAndATopLevelArray) {
  JsonWriter w;
  w.begin_array().begin_array().end_array().begin_object().end_object().end_array();
  EXPECT_EQ(w.text(), "[[],{}]");
}

TEST(JsonWriter, Rfc8259_7_StringsAreQuotedAndEscaped) {
  JsonWriter w;
  w.begin_object().field("k\"", std::string("a\"b\\c\nd\te\x01\x7f")).field("utf8", "Drehgeber \xC3\xBC");
  EXPECT_EQ(w.end_object().take(), "{\"k\\\"\":\"a\\\"b\\\\c\\nd\\te\\u0001\\u007f\",\"utf8\":\"Drehgeber \xC3\xBC\"}");
}

TEST(JsonWriter, ANullCStringIsTheEmptyString) {
  JsonWriter w;
  const char* none = nullptr;
  EXPECT_EQ(w.begin_array().value(none).end_array().take(), R"([""])");
}

TEST(JsonWriter, IntegersOfEveryWidthAndSign) {
  JsonWriter w;
  w.begin_array().value(std::uint8_t{255}).value(std::int16_t{-32768}).value(std::uint32_t{4294967295U});
  w.value(std::numeric_limits<std::uint64_t>::max()).value(std::numeric_limits<std::int64_t>::min());
  EXPECT_EQ(w.end_array().take(), "[255,-32768,4294967295,18446744073709551615,-9223372036854775808]");
}

TEST(JsonWriter, Rfc8259_6_NumbersJsonCannotHoldAreNull) {
  JsonWriter w;
  w.begin_array().value(std::nan("")).exact(std::numeric_limits<double>::infinity()).fixed(-HUGE_VAL, 2);
  EXPECT_EQ(w.end_array().take(), "[null,null,null]");
}

TEST(JsonWriter, DoublesToThreeDecimalsOrExact) {
  JsonWriter w;
  w.begin_array().value(1.23456).fixed(2.5, 1).exact(0.1).end_array();
  EXPECT_EQ(w.take(), "[1.235,2.5,0.10000000000000001]");
}

TEST(JsonWriter, AnEncodedDocumentIsEmbeddedAsAValue) {
  JsonWriter w;
  w.begin_object().field("ok", false).key("error").raw(R"({"code":"timeout"})").field("n", 1);
  EXPECT_EQ(w.end_object().take(), R"({"ok":false,"error":{"code":"timeout"},"n":1})");
}

}  // namespace
