// ControlRequest: the control socket's request lines for clients' SDO / NMT /
// LSS commands (docs/operations.md "Control socket").
#include "control/control_request.hpp"

#include <gtest/gtest.h>

namespace bus = cobridge::bus;

using cobridge::Errc;
using cobridge::control::ControlRequest;
using cobridge::bus::LssStep;
using cobridge::control::parse_control_request;
using cobridge::bus::ServiceOp;

TEST(ControlRequest, SdoReadOfAnObject) {
  const auto r = parse_control_request("sdo-read vcan0 10 1018 4 250");
  ASSERT_EQ(r.kind, ControlRequest::Kind::service) << r.error.message;
  EXPECT_EQ(r.bus, "vcan0");
  EXPECT_EQ(r.command.op, bus::ServiceOp::sdo_upload);
  EXPECT_EQ(r.command.node, 10);
  EXPECT_EQ(r.command.index, 0x1018);
  EXPECT_EQ(r.command.sub, 4);
  EXPECT_EQ(r.command.sdo_timeout.count(), 250);
  EXPECT_FALSE(r.command.is_write());
}

TEST(ControlRequest, SdoWriteCarriesTheWireBytes) {
  const auto r = parse_control_request("sdo-write line1 20 1017 0 6400");
  ASSERT_EQ(r.kind, ControlRequest::Kind::service) << r.error.message;
  EXPECT_EQ(r.command.data, (std::vector<std::uint8_t>{0x64, 0x00}));
  EXPECT_TRUE(r.command.is_write());
}

TEST(ControlRequest, NmtAndLss) {
  const auto n = parse_control_request("nmt line1 reset-comm 0");
  ASSERT_EQ(n.kind, ControlRequest::Kind::service);
  EXPECT_EQ(n.command.op, bus::ServiceOp::nmt);
  EXPECT_EQ(n.command.nmt, cobridge::canopen::NmtCommand::reset_comm);
  EXPECT_EQ(n.command.node, 0);
  const auto l = parse_control_request("lss-set-node-id line1 0x4E 0x1234 1 1001 12 store");
  ASSERT_EQ(l.kind, ControlRequest::Kind::service) << l.error.message;
  ASSERT_EQ(l.command.lss_steps.size(), 4U);
  EXPECT_EQ(l.command.lss_steps[0].kind, bus::LssStep::Kind::switch_selective);
  EXPECT_EQ(l.command.lss_steps[0].address.serial, 1001U);
  EXPECT_EQ(l.command.lss_steps[1].value, 12U);
  EXPECT_EQ(l.command.lss_steps[3].kind, bus::LssStep::Kind::switch_global);
}

TEST(ControlRequest, BadArgumentsAreInvalidArgument) {
  for (const char* line : {"sdo-read vcan0 0 1018 4", "sdo-read vcan0 128 1018 4", "sdo-read vcan0 10 10000 0",
                           "sdo-read vcan0 10 1018 256", "sdo-write vcan0 10 1018 0 ABC", "nmt vcan0 jump 1",
                           "sdo-read vcan0 10 1018 4 5", "lss-set-node-id a 1 2 3 4 0 store", "nmt vcan0 stop"}) {
    const auto r = parse_control_request(line);
    EXPECT_EQ(r.kind, ControlRequest::Kind::invalid) << line;
    EXPECT_EQ(r.error.kind, Errc::kInvalidArgument) << line;
  }
}
