// AsciiRequest: CiA 309-3 (ASCII gateway) command lines and value encodings:
// request syntax "[seq] [[net] node] command", the
// error numbers 100..107 and 50x, the data types of the standard's table.
#include "control/ascii/ascii_request.hpp"

#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

namespace bus = cobridge::bus;

using cobridge::control::AsciiError;
using cobridge::control::AsciiRequest;
using cobridge::control::AsciiType;
using cobridge::bus::LssStep;
using cobridge::bus::ServiceOp;
using cobridge::control::ascii_format;
using cobridge::control::parse_ascii_request;

TEST(AsciiRequest, ReadWithNetNodeAndType) {
  const auto r = parse_ascii_request("[12] 1 10 read 0x1017 0 u16");
  ASSERT_EQ(r.kind, AsciiRequest::Kind::read);
  EXPECT_EQ(r.seq, "12");
  EXPECT_EQ(r.net, 1U);
  EXPECT_EQ(r.node, 10);
  EXPECT_EQ(r.type, AsciiType::u16);
  EXPECT_EQ(r.command.index, 0x1017);
  const auto s = parse_ascii_request("[1] 10 r 0x1008 0 vs");
  ASSERT_EQ(s.kind, AsciiRequest::Kind::read);
  EXPECT_EQ(s.net, 0U);
  EXPECT_EQ(s.node, 10);
  const auto d = parse_ascii_request("[2] r 0x1018 4");
  ASSERT_EQ(d.kind, AsciiRequest::Kind::read);
  EXPECT_EQ(d.node, -1);  // the connection's default node
}

TEST(AsciiRequest, WriteEncodesLittleEndian) {
  const auto r = parse_ascii_request("[3] 10 w 0x1017 0 u16 1000");
  ASSERT_EQ(r.kind, AsciiRequest::Kind::write);
  EXPECT_EQ(r.command.op, bus::ServiceOp::sdo_download);
  EXPECT_EQ(r.command.data, (std::vector<std::uint8_t>{0xE8, 0x03}));
  const auto i = parse_ascii_request("[4] 10 w 0x2000 0 i8 -2");
  EXPECT_EQ(i.command.data, (std::vector<std::uint8_t>{0xFE}));
  const auto v = parse_ascii_request("[5] 10 w 0x2001 0 vs \"a \"\"b\"\"\"");
  ASSERT_EQ(v.kind, AsciiRequest::Kind::write);
  EXPECT_EQ(std::string(v.command.data.begin(), v.command.data.end()), "a \"b\"");
  EXPECT_EQ(parse_ascii_request("[6] 10 w 0x1017 0 u8 256").error, AsciiError::syntax);
}

TEST(AsciiRequest, NmtLssSetInfo) {
  EXPECT_EQ(parse_ascii_request("[1] 10 start").command.nmt, cobridge::canopen::NmtCommand::start);
  EXPECT_EQ(parse_ascii_request("[1] 10 reset comm").command.nmt, cobridge::canopen::NmtCommand::reset_comm);
  EXPECT_EQ(parse_ascii_request("[1] 0 preop").node, 0);
  const auto l = parse_ascii_request("[7] 1 lss_switch_sel 0x4E 2 3 1001");
  ASSERT_EQ(l.kind, AsciiRequest::Kind::lss);
  EXPECT_EQ(l.net, 1U);
  EXPECT_EQ(l.command.lss_steps[0].kind, bus::LssStep::Kind::switch_selective);
  EXPECT_EQ(parse_ascii_request("[8] lss_inquire_addr").command.lss_steps.size(), 4U);
  EXPECT_EQ(parse_ascii_request("[9] lss_set_node 200").error, AsciiError::lss_node_id);
  EXPECT_EQ(parse_ascii_request("[9] set node 5").kind, AsciiRequest::Kind::set_node);
  EXPECT_EQ(parse_ascii_request("[9] info version").kind, AsciiRequest::Kind::info);
}

TEST(AsciiRequest, ErrorsHaveTheStandardsNumbers) {
  EXPECT_EQ(parse_ascii_request("10 read 0x1000 0").error, AsciiError::syntax);  // no [seq]
  EXPECT_EQ(parse_ascii_request("[x] 10 read 0x1000 0").error, AsciiError::syntax);
  EXPECT_EQ(parse_ascii_request("[1] 10 read").error, AsciiError::syntax);
  EXPECT_EQ(parse_ascii_request("[1] 10 read 0x10000 0").error, AsciiError::syntax);
  EXPECT_EQ(parse_ascii_request("[1] 10 jump").error, AsciiError::not_supported);
  EXPECT_EQ(parse_ascii_request("[1] 10 read 0x1000 0 d").error, AsciiError::not_supported);
  EXPECT_EQ(parse_ascii_request("[1] lss_conf_bitrate 0 4").error, AsciiError::not_supported);
  EXPECT_EQ(parse_ascii_request("[1] 10 read 0x1000 0 q16").error, AsciiError::syntax);
  EXPECT_EQ(parse_ascii_request(std::string("[1] \x01\xff\0 r", 9)).kind, AsciiRequest::Kind::invalid);
}

TEST(AsciiRequest, FormatsByType) {
  const std::uint8_t two[] = {0xE8, 0x03};
  EXPECT_EQ(ascii_format(AsciiType::u16, two), "1000");
  EXPECT_EQ(ascii_format(AsciiType::x16, two), "0x03E8");
  const std::uint8_t neg[] = {0xFE, 0xFF};
  EXPECT_EQ(ascii_format(AsciiType::i16, neg), "-2");
  EXPECT_EQ(ascii_format(AsciiType::u32, two), std::nullopt);  // size does not fit the type
  const std::uint8_t name[] = {'R', 'M', '"', '9'};
  EXPECT_EQ(ascii_format(AsciiType::vs, name), "\"RM\"\"9\"");
  EXPECT_EQ(ascii_format(AsciiType::none, two), "E803");
}

// CiA 309-3 (answer syntax): every answer ends with CR LF; `cocomm` reads up
// to "\r\n" and waits for ever on a bare LF.
TEST(AsciiRequest, AnswerLinesEndWithCrLf) {
  using cobridge::control::ascii_abort;
  using cobridge::control::ascii_error;
  using cobridge::control::ascii_line;
  using cobridge::control::ascii_ok;
  EXPECT_EQ(ascii_line(ascii_ok("1")), "[1] OK\r\n");
  EXPECT_EQ(ascii_line(ascii_error("2", AsciiError::syntax)), "[2] ERROR: 101\r\n");
  EXPECT_EQ(ascii_line(ascii_abort("3", 0x06020000)), "[3] ERROR: 0x06020000\r\n");
  EXPECT_EQ(ascii_line("[4] 1001"), "[4] 1001\r\n");
}

// CiA 309-3 (request syntax): a request ended by CR LF is the request ended by LF.
TEST(AsciiRequest, ATrailingCrIsNoPartOfTheLastWord) {
  const auto r = parse_ascii_request("[3] 10 w 0x1017 0 u16 1000\r");
  ASSERT_EQ(r.kind, AsciiRequest::Kind::write);
  EXPECT_EQ(r.command.data, (std::vector<std::uint8_t>{0xE8, 0x03}));
  EXPECT_EQ(parse_ascii_request("[4] 10 w 0x2001 0 vs abc\r").command.data,
            (std::vector<std::uint8_t>{'a', 'b', 'c'}));
}

namespace {

// One write of `text` as `type`: the little-endian value it writes, or
// nullopt when refused (then with ERROR: 101).
struct IntegerCase {
  const char* type;
  const char* text;
  std::optional<std::uint64_t> bits;  // the value written, as the type's bit pattern
};

constexpr std::uint64_t kMaxU64 = ~0ULL;

// CiA 309-3 §5 (numbers, decimal or 0x-hex) and the data types of CiA 301
// §7.1: each integer type's minimum, maximum, one past each, in every form
// (decimal, '-', 0x, -0x); hex for a signed type is a magnitude, never a
// bit pattern (0xFFFF is no i16); a leading 0 before digits is refused (octal
// to CANopenNode).
const IntegerCase kIntegerCases[] = {
    {"b", "0", 0}, {"b", "1", 1}, {"b", "2", {}}, {"b", "0x1", 1}, {"b", "0x2", {}}, {"b", "-0", {}}, {"b", "-1", {}},
    {"i8", "-128", 0x80}, {"i8", "127", 0x7F}, {"i8", "128", {}}, {"i8", "-129", {}}, {"i8", "0x7F", 0x7F},
    {"i8", "0x80", {}}, {"i8", "0xFF", {}}, {"i8", "-0x80", 0x80}, {"i8", "-0x81", {}}, {"i8", "-1", 0xFF},
    {"i8", "-0", 0},
    {"i16", "-32768", 0x8000}, {"i16", "32767", 0x7FFF}, {"i16", "32768", {}}, {"i16", "-32769", {}},
    {"i16", "0x7FFF", 0x7FFF}, {"i16", "0x8000", {}}, {"i16", "0xFFFF", {}}, {"i16", "0x12345", {}},
    {"i16", "-0x8000", 0x8000}, {"i16", "-0x8001", {}}, {"i16", "-1", 0xFFFF}, {"i16", "-0x1", 0xFFFF},
    {"i32", "-2147483648", 0x80000000}, {"i32", "2147483647", 0x7FFFFFFF}, {"i32", "2147483648", {}},
    {"i32", "-2147483649", {}}, {"i32", "0x7FFFFFFF", 0x7FFFFFFF}, {"i32", "0x80000000", {}},
    {"i32", "0xFFFFFFFF", {}}, {"i32", "0x100000000", {}}, {"i32", "-0x80000000", 0x80000000},
    {"i32", "-0x80000001", {}},
    {"i64", "-9223372036854775808", 0x8000000000000000}, {"i64", "9223372036854775807", 0x7FFFFFFFFFFFFFFF},
    {"i64", "9223372036854775808", {}}, {"i64", "-9223372036854775809", {}},
    {"i64", "0x7FFFFFFFFFFFFFFF", 0x7FFFFFFFFFFFFFFF}, {"i64", "0x8000000000000000", {}},
    {"i64", "0xFFFFFFFFFFFFFFFF", {}}, {"i64", "0x10000000000000000", {}},
    {"i64", "-0x8000000000000000", 0x8000000000000000}, {"i64", "-0x8000000000000001", {}}, {"i64", "-1", kMaxU64},
    {"u8", "0", 0}, {"u8", "255", 0xFF}, {"u8", "256", {}}, {"u8", "-1", {}}, {"u8", "-0", {}}, {"u8", "0xFF", 0xFF},
    {"u8", "0x100", {}},
    {"u16", "65535", 0xFFFF}, {"u16", "65536", {}}, {"u16", "0xFFFF", 0xFFFF}, {"u16", "0x10000", {}},
    {"u16", "-1", {}},
    {"u32", "4294967295", 0xFFFFFFFF}, {"u32", "4294967296", {}}, {"u32", "0xFFFFFFFF", 0xFFFFFFFF},
    {"u32", "0x100000000", {}}, {"u32", "-1", {}},
    {"u64", "18446744073709551615", kMaxU64}, {"u64", "18446744073709551616", {}},
    {"u64", "0xFFFFFFFFFFFFFFFF", kMaxU64}, {"u64", "0x10000000000000000", {}}, {"u64", "-1", {}},
    {"x8", "0xFF", 0xFF}, {"x8", "255", 0xFF}, {"x8", "0x100", {}}, {"x8", "256", {}}, {"x8", "-1", {}},
    {"x16", "0xFFFF", 0xFFFF}, {"x16", "0x10000", {}}, {"x16", "65536", {}},
    {"x32", "0xFFFFFFFF", 0xFFFFFFFF}, {"x32", "0x100000000", {}}, {"x32", "4294967296", {}},
    {"x64", "0xFFFFFFFFFFFFFFFF", kMaxU64}, {"x64", "0x10000000000000000", {}}, {"x64", "18446744073709551616", {}},
    // Not numbers of any form: refused for every type.
    {"i16", "0x", {}}, {"i16", "-0x", {}}, {"i16", "-", {}}, {"i16", "+1", {}}, {"i16", "--1", {}}, {"i16", "1.0", {}},
    {"i16", "1e3", {}}, {"i16", "0x1g", {}}, {"u16", "0x-1", {}}, {"u16", "+1", {}},
    // Octal to CANopenNode (strtol base 0), decimal to us: refused, not guessed.
    {"u8", "010", {}}, {"i8", "-010", {}}, {"u16", "00", {}}, {"u8", "0", 0}, {"i8", "-0", 0},
};

std::size_t width_of(std::string_view type) {
  if (type == "b") return 1;
  return static_cast<std::size_t>(std::stoi(std::string(type.substr(1)))) / 8;
}

}  // namespace

// "[1] 10 w 0x6003 0 i16 0x12345" must not write 0x2345.
TEST(AsciiRequest, AValueItsTypeCannotHoldIsASyntaxError) {
  const auto r = parse_ascii_request("[1] 10 w 0x6003 0 i16 0x12345");
  EXPECT_EQ(r.kind, AsciiRequest::Kind::invalid);
  EXPECT_EQ(r.error, AsciiError::syntax);
  EXPECT_TRUE(r.command.data.empty());
}

// Found by the fuzz target's "accepted implies representable": a control
// byte 0x01 at a word's start passed for the parser's mark of a quoted word.
TEST(AsciiRequest, AControlByteIsNoQuote) {
  EXPECT_EQ(parse_ascii_request("[1] 10 w 0x2000 0 i16 \x01" "6").error, AsciiError::syntax);
  EXPECT_EQ(parse_ascii_request("[1] 10 w 0x2000 0 vs \x01" "abc").error, AsciiError::syntax);
}

TEST(AsciiRequest, EveryIntegerFormIsRangeCheckedForItsType) {
  for (const auto& c : kIntegerCases) {
    const std::string line = std::string("[1] 10 w 0x2000 0 ") + c.type + " " + c.text;
    const auto r = parse_ascii_request(line);
    if (!c.bits) {
      EXPECT_EQ(r.kind, AsciiRequest::Kind::invalid) << line;
      EXPECT_EQ(r.error, AsciiError::syntax) << line;
      continue;
    }
    ASSERT_EQ(r.kind, AsciiRequest::Kind::write) << line;
    std::vector<std::uint8_t> want;
    for (std::size_t i = 0; i < width_of(c.type); ++i) want.push_back(static_cast<std::uint8_t>(*c.bits >> (8 * i)));
    EXPECT_EQ(r.command.data, want) << line;
  }
}

// CiA 301 §7.1.4 REAL32/REAL64: a value the type cannot hold (1e39 as r32
// would become infinity), one too small to keep (1e-50 would become 0),
// "inf", "nan" and leading blanks are refused like an integer out of range.
TEST(AsciiRequest, ARealItsTypeCannotHoldIsASyntaxError) {
  for (const char* bad : {"[1] 10 w 0x2000 0 r32 1e39", "[1] 10 w 0x2000 0 r32 1e-50", "[1] 10 w 0x2000 0 r32 inf",
                          "[1] 10 w 0x2000 0 r64 nan", "[1] 10 w 0x2000 0 r64 1e309", "[1] 10 w 0x2000 0 r64 -inf"}) {
    const auto r = parse_ascii_request(bad);
    EXPECT_EQ(r.kind, AsciiRequest::Kind::invalid) << bad;
  }
  const auto ok = parse_ascii_request("[1] 10 w 0x2000 0 r32 -1.5");
  ASSERT_EQ(ok.kind, AsciiRequest::Kind::write);
  EXPECT_EQ(ok.command.data, (std::vector<std::uint8_t>{0x00, 0x00, 0xC0, 0xBF}));
}
