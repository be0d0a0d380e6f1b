// ServiceExecutor: a client's SDO / NMT command run by the daemon
// against a recording sink and a scripted gate; the frames are the
// CiA 301 §7.2.4.3 expedited upload (0x40 -> 0x43..0x4F) and abort (0x80),
// §7.2.8.3.3 boot-up (0x700 + node, one byte 0x00).
#include "bus/service/service_executor.hpp"

#include "scripted_gate.hpp"

#include <gtest/gtest.h>
#include <poll.h>

#include <set>
#include <vector>

using namespace std::chrono_literals;
using cobridge::Errc;
using cobridge::can::Frame;
using cobridge::canopen::TimePoint;
namespace gw = cobridge::bus;

namespace {

Frame frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  Frame f;
  f.id = id;
  f.len = static_cast<std::uint8_t>(bytes.size());
  std::size_t i = 0;
  for (auto b : bytes) f.data[i++] = b;
  return f;
}


struct ServiceExecutorTest : ::testing::Test, gw::testing::ServiceBus {};

}  // namespace

// Rule: a command never interleaves with the daemon's own work on the node:
// nothing is sent while the gate says the node is busy, and it starts once free.
TEST_F(ServiceExecutorTest, WaitsForABusyNodeThenReads) {
  gate.busy.insert(10);
  ex.add(upload(10), replies, t0);
  ex.process(t0, gate);
  ex.process(t0 + 500ms, gate);
  EXPECT_TRUE(bus.sent.empty());
  EXPECT_EQ(ex.sdo_node(), 0);
  gate.busy.clear();
  ex.process(t0 + 600ms, gate);
  ASSERT_EQ(bus.sent.size(), 1U);
  EXPECT_EQ(bus.sent[0].id, 0x60AU);
  EXPECT_EQ(bus.sent[0].data[0], 0x40);
  EXPECT_EQ(ex.sdo_node(), 10);
  ex.on_frame(frame(0x58A, {0x43, 0x18, 0x10, 0x04, 0xE9, 0x03, 0x00, 0x00}), t0 + 601ms);
  ex.process(t0 + 601ms, gate);
  const auto r = replies->take();
  ASSERT_EQ(r.size(), 1U);
  EXPECT_FALSE(r[0].error);
  EXPECT_EQ(r[0].tag, 7U);
  EXPECT_EQ(r[0].data, (std::vector<std::uint8_t>{0xE9, 0x03, 0, 0}));
}

// CiA 301 §7.2.8.3.3: a boot-up mid-transfer ends the transfer in the device;
// the read starts again once the node is free, and the abort a reboot would
// cause never reaches the client.
TEST_F(ServiceExecutorTest, BootUpMidTransferRestartsTheRead) {
  gate.supervised.insert(10);
  ex.add(upload(10), replies, t0);
  ex.process(t0, gate);
  ASSERT_EQ(bus.sent.size(), 1U);
  ex.on_frame(frame(0x70A, {0x00}), t0 + 5ms);
  gate.busy.insert(10);  // the bus manager configures it again
  ex.process(t0 + 100ms, gate);
  EXPECT_EQ(bus.sent.size(), 1U);
  EXPECT_TRUE(replies->take().empty());
  gate.busy.clear();
  ex.process(t0 + 300ms, gate);
  ASSERT_EQ(bus.sent.size(), 2U);
  EXPECT_EQ(bus.sent[1].data[0], 0x40);
  ex.on_frame(frame(0x58A, {0x43, 0x18, 0x10, 0x04, 1, 2, 3, 4}), t0 + 301ms);
  ex.process(t0 + 301ms, gate);
  const auto r = replies->take();
  ASSERT_EQ(r.size(), 1U);
  EXPECT_FALSE(r[0].error) << r[0].error.to_string();
}

// CiA 301 §7.2.4.3.17: a device's abort is the answer (exit code 1, the code kept).
TEST_F(ServiceExecutorTest, DeviceAbortIsReportedWithItsCode) {
  ex.add(upload(10), replies, t0);
  ex.process(t0, gate);
  ex.on_frame(frame(0x58A, {0x80, 0x18, 0x10, 0x04, 0x00, 0x00, 0x02, 0x06}), t0 + 1ms);
  ex.process(t0 + 1ms, gate);
  const auto r = replies->take();
  ASSERT_EQ(r.size(), 1U);
  EXPECT_EQ(r[0].error.kind, Errc::kFailed);
  EXPECT_EQ(r[0].abort_code, 0x06020000U);
}

// Silence from a node no configured device holds is a timeout at once (no
// reboot to wait for).
TEST_F(ServiceExecutorTest, SilenceFromAnUnknownNodeIsATimeout) {
  ex.add(upload(99), replies, t0);
  ex.process(t0, gate);
  ex.process(t0 + 150ms, gate);
  const auto r = replies->take();
  ASSERT_EQ(r.size(), 1U);
  EXPECT_EQ(r[0].error.kind, Errc::kTimeout);
}

// A node that stays busy past the deadline: a timeout naming why.
TEST_F(ServiceExecutorTest, DeadlineWhileWaitingIsATimeout) {
  gate.busy.insert(10);
  ex.add(upload(10), replies, t0);
  ex.process(t0 + 2001ms, gate);
  const auto r = replies->take();
  ASSERT_EQ(r.size(), 1U);
  EXPECT_EQ(r[0].error.kind, Errc::kTimeout);
  EXPECT_NE(r[0].error.message.find("busy"), std::string::npos);
}

// A command for a busy node does not hold up one for another node.
TEST_F(ServiceExecutorTest, BusyNodeDoesNotBlockOthers) {
  gate.busy.insert(10);
  ex.add(upload(10), replies, t0);
  ex.add(upload(20), replies, t0);
  ex.process(t0, gate);
  ASSERT_EQ(bus.sent.size(), 1U);
  EXPECT_EQ(bus.sent[0].id, 0x614U);
}

// CiA 301 §7.2.8.3.1: NMT is one frame 0x000 [cs, node]; the gate learns it.
TEST_F(ServiceExecutorTest, NmtIsSentAndReported) {
  gw::ServiceRequest c;
  c.op = gw::ServiceOp::nmt;
  c.nmt = cobridge::canopen::NmtCommand::stop;
  c.node = 20;
  ex.add(c, replies, t0);
  ex.process(t0, gate);
  ASSERT_EQ(bus.sent.size(), 1U);
  EXPECT_EQ(bus.sent[0].id, 0x000U);
  EXPECT_EQ(bus.sent[0].data[0], 0x02);
  EXPECT_EQ(bus.sent[0].data[1], 20);
  EXPECT_EQ(gate.nmt, (std::vector<std::uint8_t>{20}));
  EXPECT_EQ(replies->take().size(), 1U);
}

namespace {

gw::ServiceRequest lss(std::initializer_list<gw::LssStep> steps) {
  gw::ServiceRequest c;
  c.op = gw::ServiceOp::lss;
  c.lss_steps = steps;
  c.tag = 9;
  return c;
}

gw::LssStep step(gw::LssStep::Kind kind, std::uint32_t value = 0) {
  gw::LssStep s;
  s.kind = kind;
  s.value = value;
  return s;
}

}  // namespace

// CiA 305 §8.3.2: only a device in configuration state answers an inquiry.
// After "switch state global: waiting" nobody is; an inquiry nobody answers
// then proves no session, so discovery (which waits out a session) is not
// held for 10 s: the case where a power-cycled device came back through the
// 500 ms fallback instead of discovery's re-identification (the
// gateway test no_stall runs within 10 s of such an inquiry).
TEST_F(ServiceExecutorTest, InquiryNobodyAnswersOutsideASessionHoldsNothing) {
  ex.add(lss({step(gw::LssStep::Kind::switch_global, 1)}), replies, t0);
  ex.process(t0, gate);
  EXPECT_TRUE(ex.lss_session(t0 + 5s));  // devices may be in configuration state
  ex.add(lss({step(gw::LssStep::Kind::switch_global, 0)}), replies, t0 + 1s);
  ex.process(t0 + 1s, gate);
  EXPECT_FALSE(ex.lss_session(t0 + 1s));
  ex.add(lss({step(gw::LssStep::Kind::inquire_node_id)}), replies, t0 + 2s);
  ex.process(t0 + 2s, gate);
  ASSERT_EQ(bus.sent.size(), 3U);
  EXPECT_EQ(bus.sent[2].id, 0x7E5U);
  EXPECT_EQ(bus.sent[2].data[0], 0x5E);
  EXPECT_TRUE(ex.lss_session(t0 + 2s));  // while the command runs
  ex.process(t0 + 2s + 150ms, gate);     // the LSS timeout (100 ms) passed
  const auto r = replies->take();
  ASSERT_EQ(r.size(), 3U);
  EXPECT_EQ(r[2].error.kind, Errc::kTimeout);
  EXPECT_FALSE(ex.lss_session(t0 + 2s + 150ms));
}

// An inquiry a device answers shows a device in configuration state: the
// session is held again, whoever opened it.
TEST_F(ServiceExecutorTest, AnsweredInquiryHoldsTheSession) {
  ex.add(lss({step(gw::LssStep::Kind::inquire_node_id)}), replies, t0);
  ex.process(t0, gate);
  ex.on_frame(frame(0x7E4, {0x5E, 20, 0, 0, 0, 0, 0, 0}), t0 + 5ms);
  ex.process(t0 + 5ms, gate);
  const auto r = replies->take();
  ASSERT_EQ(r.size(), 1U);
  EXPECT_FALSE(r[0].error);
  EXPECT_EQ(r[0].value & 0xFF, 20U);
  EXPECT_TRUE(ex.lss_session(t0 + 9s));
  EXPECT_FALSE(ex.lss_session(t0 + 11s));
}

// The bus stopping: the running command and every queued one end with an
// error, each result tagged for its client's server, so no client waits on
// a bus that is gone.
TEST_F(ServiceExecutorTest, TheBusStoppingEndsEveryCommandWithAnError) {
  gw::ServiceRequest queued = upload(11);
  queued.tag = 8;
  ex.add(upload(10), replies, t0);
  ex.add(std::move(queued), replies, t0);
  ex.process(t0, gate);
  ASSERT_EQ(ex.sdo_node(), 10);
  ex.abort_all("the bus stopped");
  pollfd p{replies->fd(), POLLIN, 0};
  EXPECT_EQ(::poll(&p, 1, 0), 1) << "the clients' server was not woken";
  const auto r = replies->take();
  ASSERT_EQ(r.size(), 2U);
  EXPECT_EQ(r[0].tag, 7U);
  EXPECT_EQ(r[1].tag, 8U);
  for (const auto& res : r) EXPECT_EQ(res.error.kind, Errc::kUnavailable);
  EXPECT_EQ(ex.waiting(), 0U);
}

// A confirmed download (CiA 301 §7.2.4.3.3: 0x2B -> 0x60) reaches the gate,
// with its caller, for the configuration-drift check; a refused one (0x80)
// does not: the device kept its value.
TEST_F(ServiceExecutorTest, ConfirmedDownloadsReachTheGate) {
  gw::ServiceRequest c = upload(10);
  c.op = gw::ServiceOp::sdo_download;
  c.index = 0x1017;
  c.sub = 0;
  c.data = {0x45, 0x23};
  c.caller = "tcp 10.0.0.5 (CiA 309-3 gateway)";
  ex.add(c, replies, t0);
  ex.process(t0, gate);
  ASSERT_EQ(bus.sent.size(), 1U);
  EXPECT_EQ(bus.sent[0].data[0], 0x2B);
  ex.on_frame(frame(0x58A, {0x60, 0x17, 0x10, 0x00, 0, 0, 0, 0}), t0 + 1ms);
  ex.process(t0 + 1ms, gate);
  ASSERT_EQ(gate.written.size(), 1U);
  EXPECT_EQ(gate.written[0].index, 0x1017);
  EXPECT_EQ(gate.written[0].data, (std::vector<std::uint8_t>{0x45, 0x23}));
  EXPECT_EQ(gate.written[0].caller, "tcp 10.0.0.5 (CiA 309-3 gateway)");
  EXPECT_EQ(replies->take().size(), 1U);

  ex.add(c, replies, t0 + 2ms);
  ex.process(t0 + 2ms, gate);
  ex.on_frame(frame(0x58A, {0x80, 0x17, 0x10, 0x00, 0x30, 0x00, 0x09, 0x06}), t0 + 3ms);  // 0x06090030
  ex.process(t0 + 3ms, gate);
  EXPECT_EQ(gate.written.size(), 1U) << "an aborted download changed nothing";
}
