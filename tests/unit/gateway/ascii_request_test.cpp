// AsciiRequest: CiA 309-3 (ASCII gateway) command lines and value encodings
// (issue 15, item 3): request syntax "[seq] [[net] node] command", the
// error numbers 100..107 and 50x, the data types of the standard's table.
#include "gateway/remote/ascii_request.hpp"

#include <gtest/gtest.h>

using cobridge::gateway::AsciiError;
using cobridge::gateway::AsciiRequest;
using cobridge::gateway::AsciiType;
using cobridge::gateway::LssStep;
using cobridge::gateway::RemoteOp;
using cobridge::gateway::ascii_format;
using cobridge::gateway::parse_ascii_request;

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
  EXPECT_EQ(r.command.op, RemoteOp::sdo_download);
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
  EXPECT_EQ(l.command.lss_steps[0].kind, LssStep::Kind::switch_selective);
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
