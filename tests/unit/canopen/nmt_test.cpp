#include "canopen/nmt.hpp"

#include <gtest/gtest.h>

namespace cobridge::canopen {
namespace {

using can::Frame;

// CiA 301 §7.2.8.3.1; the ifm manual prints the same frames: F§6.1.2 `80 NN`,
// F§6.1.3 `01 NN`, F§6.1.4 `02 NN`, F§6.1.5 `81 NN`.
TEST(Nmt, F6_1_CommandFramesMatchManual) {
  EXPECT_EQ(make_nmt(NmtCommand::enter_preop, 0x20), Frame::make(0x000, {0x80, 0x20}));
  EXPECT_EQ(make_nmt(NmtCommand::start, 0x20), Frame::make(0x000, {0x01, 0x20}));
  EXPECT_EQ(make_nmt(NmtCommand::stop, 0x20), Frame::make(0x000, {0x02, 0x20}));
  EXPECT_EQ(make_nmt(NmtCommand::reset_node, 0x20), Frame::make(0x000, {0x81, 0x20}));
  EXPECT_EQ(make_nmt(NmtCommand::reset_comm, 0x7F), Frame::make(0x000, {0x82, 0x7F}));
  // Node 0 addresses every node (F§6.1: "byte 1 = 0 means all nodes").
  EXPECT_EQ(make_nmt(NmtCommand::start, 0), Frame::make(0x000, {0x01, 0x00}));
}

// CiA 301 §7.2.8.3.1: DLC 2, cs in byte 0, node-ID in byte 1.
TEST(Nmt, CiA301_7_2_8_3_1_ParseCommand) {
  const NmtCommandParse p = parse_nmt(Frame::make(0x000, {0x82, 0x05}));
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(p.frame.command, NmtCommand::reset_comm);
  EXPECT_EQ(p.frame.node, 5);
  EXPECT_TRUE(p.frame.addresses(5));
  EXPECT_FALSE(p.frame.addresses(6));
  EXPECT_TRUE(parse_nmt(Frame::make(0x000, {0x01, 0x00})).frame.addresses(42));
}

// CiA 301 §7.2.8.3.1: malformed NMT frames are not commands.
TEST(Nmt, CiA301_7_2_8_3_1_RejectsMalformedCommands) {
  EXPECT_EQ(parse_nmt(Frame::make(0x000, {0x01})).error, NmtFrameError::wrong_length);
  EXPECT_EQ(parse_nmt(Frame::make(0x000, {0x01, 0x01, 0x00})).error, NmtFrameError::wrong_length);
  EXPECT_EQ(parse_nmt(Frame::make(0x000, {0x03, 0x01})).error, NmtFrameError::unknown_command);
  EXPECT_EQ(parse_nmt(Frame::make(0x000, {0x01, 0x80})).error, NmtFrameError::invalid_node);
  EXPECT_EQ(parse_nmt(Frame::make(0x001, {0x01, 0x01})).error, NmtFrameError::wrong_cob_id);
  Frame rtr = Frame::make(0x000, {0x01, 0x01});
  rtr.flags = Frame::kFlagRtr;
  EXPECT_EQ(parse_nmt(rtr).error, NmtFrameError::remote_request);
  Frame ext = Frame::make(0x000, {0x01, 0x01});
  ext.flags = Frame::kFlagExtended;
  EXPECT_EQ(parse_nmt(ext).error, NmtFrameError::extended_id);
}

// F§6.1.1 / CiA 301 §7.2.8.3.3: boot-up is 0x700 + node with one byte 00.
TEST(Nmt, F6_1_1_BootUpFrame) {
  EXPECT_EQ(make_boot_up(0x20), Frame::make(0x720, {0x00}));
  const ErrorControlParse p = parse_error_control(Frame::make(0x720, {0x00}));
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(p.message.node, 0x20);
  EXPECT_TRUE(p.message.is_boot_up);
  EXPECT_EQ(p.message.state, NmtState::boot_up);
}

// CiA 301 §7.2.8.3.2.2: heartbeat state byte 04 stopped, 05 operational, 7F pre-op.
TEST(Nmt, CiA301_7_2_8_3_2_2_HeartbeatStates) {
  struct Case { uint8_t byte; NmtState state; };
  for (const Case c : {Case{0x04, NmtState::stopped}, Case{0x05, NmtState::operational},
                       Case{0x7F, NmtState::pre_operational}}) {
    const ErrorControlParse p = parse_error_control(Frame::make(0x77F, {c.byte}));
    ASSERT_TRUE(p.ok()) << int{c.byte};
    EXPECT_EQ(p.message.node, 127);
    EXPECT_EQ(p.message.state, c.state);
    EXPECT_FALSE(p.message.toggle);
    EXPECT_FALSE(p.message.is_boot_up);
  }
  EXPECT_EQ(make_heartbeat(3, NmtState::pre_operational), Frame::make(0x703, {0x7F}));
}

// CiA 301 §7.2.8.3.2.1: guarding reply carries the toggle in bit 7.
TEST(Nmt, CiA301_7_2_8_3_2_1_GuardReplyToggleBit) {
  const ErrorControlParse p = parse_error_control(Frame::make(0x701, {0x85}));
  ASSERT_TRUE(p.ok());
  EXPECT_TRUE(p.message.toggle);
  EXPECT_EQ(p.message.state, NmtState::operational);
  EXPECT_FALSE(p.message.is_boot_up);
  EXPECT_EQ(make_guard_reply(1, NmtState::stopped, true), Frame::make(0x701, {0x84}));
  EXPECT_EQ(make_guard_reply(1, NmtState::pre_operational, false), Frame::make(0x701, {0x7F}));
}

// CiA 301 §7.2.8.3: error-control messages have exactly one data byte.
TEST(Nmt, CiA301_7_2_8_3_RejectsMalformedErrorControl) {
  EXPECT_EQ(parse_error_control(Frame::make(0x701, {})).error, NmtFrameError::wrong_length);
  EXPECT_EQ(parse_error_control(Frame::make(0x701, {0x05, 0x00})).error,
            NmtFrameError::wrong_length);
  EXPECT_EQ(parse_error_control(Frame::make(0x701, {0x06})).error, NmtFrameError::unknown_state);
  EXPECT_EQ(parse_error_control(Frame::make(0x700, {0x05})).error, NmtFrameError::invalid_node);
  EXPECT_EQ(parse_error_control(Frame::make(0x781, {0x05})).error, NmtFrameError::wrong_cob_id);
  EXPECT_EQ(parse_error_control(Frame::make(0x181, {0x05})).error, NmtFrameError::wrong_cob_id);
  EXPECT_EQ(parse_error_control(make_guard_request(1)).error, NmtFrameError::remote_request);
}

// CiA 301 §7.2.8.3.2.1: the guarding request is a remote frame on 0x700 + node.
TEST(Nmt, CiA301_7_2_8_3_2_1_GuardRequest) {
  const Frame f = make_guard_request(0x7F);
  EXPECT_EQ(f.id, 0x77Fu);
  EXPECT_TRUE(f.is_rtr());
  EXPECT_EQ(f.len, 1);
  uint8_t node = 0;
  ASSERT_TRUE(is_guard_request(f, node));
  EXPECT_EQ(node, 0x7F);
  EXPECT_FALSE(is_guard_request(Frame::make(0x77F, {0x05}), node));
  EXPECT_FALSE(is_guard_request(make_guard_request(0), node));
}

TEST(Nmt, CiA301_7_2_8_ToStringNamesEveryValue) {
  EXPECT_EQ(to_string(NmtCommand::reset_comm), "reset communication");
  EXPECT_EQ(to_string(NmtCommand::enter_preop), "enter pre-operational");
  EXPECT_EQ(to_string(NmtState::pre_operational), "pre-operational");
  EXPECT_EQ(to_string(NmtState::boot_up), "boot-up");
  EXPECT_EQ(to_string(static_cast<NmtState>(0x33)), "unknown NMT state");
  EXPECT_EQ(to_string(NmtFrameError::wrong_length), "wrong data length");
}

// CiA 301 §7.3.2.2: after initialisation the node enters pre-operational by itself.
TEST(NmtSlaveState, CiA301_7_3_2_2_InitialisationEndsInPreOperational) {
  NmtSlaveState s;
  EXPECT_TRUE(s.initialising());
  // Nothing is processed before initialisation ends.
  EXPECT_EQ(s.apply(NmtCommand::start).outcome, NmtOutcome::ignored);
  const NmtTransition t = s.complete_initialisation();
  EXPECT_EQ(t.outcome, NmtOutcome::state_changed);
  EXPECT_EQ(t.from, NmtState::boot_up);
  EXPECT_EQ(t.to, NmtState::pre_operational);
  EXPECT_EQ(s.complete_initialisation().outcome, NmtOutcome::ignored);
}

// J§1.3.1 / E§4.1 0x1F80 bit 3: the Novotechnik sensor starts in operational.
TEST(NmtSlaveState, J1_3_1_AutostartGoesToOperational) {
  NmtSlaveState s(/*autostart=*/true);
  EXPECT_EQ(s.complete_initialisation().to, NmtState::operational);
}

// CiA 301 §7.3.2.2 state diagram, transitions (3)..(8).
TEST(NmtSlaveState, CiA301_7_3_2_2_CommandTransitions) {
  NmtSlaveState s;
  (void)s.complete_initialisation();
  struct Step { NmtCommand cmd; NmtOutcome outcome; NmtState to; };
  const Step steps[] = {
      {NmtCommand::start, NmtOutcome::state_changed, NmtState::operational},         // (3)
      {NmtCommand::start, NmtOutcome::unchanged, NmtState::operational},
      {NmtCommand::enter_preop, NmtOutcome::state_changed, NmtState::pre_operational},  // (4)
      {NmtCommand::stop, NmtOutcome::state_changed, NmtState::stopped},              // (5)
      {NmtCommand::start, NmtOutcome::state_changed, NmtState::operational},         // (6)
      {NmtCommand::stop, NmtOutcome::state_changed, NmtState::stopped},              // (8)
      {NmtCommand::enter_preop, NmtOutcome::state_changed, NmtState::pre_operational},  // (7)
  };
  for (const Step& st : steps) {
    const NmtTransition t = s.apply(st.cmd);
    EXPECT_EQ(t.outcome, st.outcome) << to_string(st.cmd);
    EXPECT_EQ(s.state(), st.to) << to_string(st.cmd);
  }
}

// CiA 301 §7.3.2.2 transitions (9)..(14): both resets from every state go
// through initialisation; F§6.1.5: after reset node the device is back in pre-op.
TEST(NmtSlaveState, CiA301_7_3_2_2_ResetsFromEveryState) {
  for (const NmtCommand reset : {NmtCommand::reset_node, NmtCommand::reset_comm}) {
    for (const NmtCommand into : {NmtCommand::enter_preop, NmtCommand::start, NmtCommand::stop}) {
      NmtSlaveState s;
      (void)s.complete_initialisation();
      (void)s.apply(into);
      const NmtTransition t = s.apply(reset);
      EXPECT_EQ(t.outcome, reset == NmtCommand::reset_node ? NmtOutcome::reset_node
                                                           : NmtOutcome::reset_communication);
      EXPECT_TRUE(s.initialising());
      EXPECT_EQ(s.complete_initialisation().to, NmtState::pre_operational);
    }
  }
}

// CiA 301 §7.2.8.3.1: a slave acts on commands for its node-ID or for all.
TEST(NmtSlaveState, CiA301_7_2_8_3_1_OnFrameAddressing) {
  NmtSlaveState s;
  (void)s.complete_initialisation();
  EXPECT_EQ(s.on_frame(make_nmt(NmtCommand::start, 9), 8).outcome, NmtOutcome::ignored);
  EXPECT_EQ(s.state(), NmtState::pre_operational);
  EXPECT_EQ(s.on_frame(make_nmt(NmtCommand::start, 8), 8).outcome, NmtOutcome::state_changed);
  EXPECT_EQ(s.on_frame(make_nmt(NmtCommand::stop, 0), 8).to, NmtState::stopped);
  EXPECT_EQ(s.on_frame(Frame::make(0x000, {0x01}), 8).outcome, NmtOutcome::ignored);
  EXPECT_EQ(s.on_frame(Frame::make(0x201, {0x01, 0x08}), 8).outcome, NmtOutcome::ignored);
}

// CiA 301 §7.3.2.2 table "NMT states and communication objects"; F§6.1.1:
// no PDOs in pre-operational.
TEST(NmtSlaveState, CiA301_7_3_2_2_ServicesPerState) {
  NmtSlaveState s;
  EXPECT_TRUE(s.allows(NmtService::boot_up));
  EXPECT_FALSE(s.allows(NmtService::sdo));
  (void)s.complete_initialisation();
  EXPECT_FALSE(s.allows(NmtService::pdo));
  EXPECT_TRUE(s.allows(NmtService::sdo));
  EXPECT_TRUE(s.allows(NmtService::emcy));
  EXPECT_TRUE(s.allows(NmtService::sync));
  EXPECT_FALSE(s.allows(NmtService::boot_up));
  (void)s.apply(NmtCommand::start);
  EXPECT_TRUE(s.allows(NmtService::pdo));
  EXPECT_TRUE(s.allows(NmtService::sdo));
  (void)s.apply(NmtCommand::stop);
  EXPECT_FALSE(s.allows(NmtService::pdo));
  EXPECT_FALSE(s.allows(NmtService::sdo));
  EXPECT_FALSE(s.allows(NmtService::emcy));
  EXPECT_TRUE(s.allows(NmtService::nmt));
  EXPECT_TRUE(s.allows(NmtService::error_control));
}

// E§4.1 0x1029 / CiA 301 §7.5.2.32: 0 = operational -> pre-op, 1 = no change, 2 = stopped.
TEST(NmtSlaveState, E4_1_ErrorBehaviour1029) {
  NmtSlaveState s;
  (void)s.complete_initialisation();
  EXPECT_EQ(s.apply_error_behaviour(0).outcome, NmtOutcome::unchanged);  // only from operational
  (void)s.apply(NmtCommand::start);
  EXPECT_EQ(s.apply_error_behaviour(1).outcome, NmtOutcome::unchanged);
  EXPECT_EQ(s.state(), NmtState::operational);
  EXPECT_EQ(s.apply_error_behaviour(0).to, NmtState::pre_operational);
  EXPECT_EQ(s.apply_error_behaviour(2).to, NmtState::stopped);
  EXPECT_EQ(s.apply_error_behaviour(2).outcome, NmtOutcome::unchanged);
}

}  // namespace
}  // namespace cobridge::canopen
