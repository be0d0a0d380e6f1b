// DeviceAgent's own decisions, with the time passed in: the configuration's
// schedule (attempts and their waits), its drift records (what a plan
// closes, what a contested object keeps out of the next plan, an operator's
// acknowledgement), the identity check of a bus without discovery (CiA 301
// §7.5.2.35: 0x1018 against the configured serial), what discovery's
// `identified` means for it (CiA 305), the standby's view of a
// device it only hears (a hot-standby pair, CiA 302-2), and what a heartbeat
// after the gateway's NMT start means (CiA 301 §7.2.8.3.2: the heartbeat carries the
// NMT state; §7.2.8.2.1.1: NMT start from the master).
#include "bus/device_agent.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "can/frame_sink.hpp"

namespace cobridge::bus {
namespace {

using namespace std::chrono_literals;
using canopen::TimePoint;

constexpr std::int64_t kStartWallNs = 1'800'000'000'000'000'000;
const TimePoint kT0{std::chrono::seconds{1000}};

std::int64_t ns(std::chrono::nanoseconds d) { return d.count(); }

TEST(DeviceAgentSchedule, WantedPlanIsDueFromItsTimeOn) {
  DeviceAgent a;
  EXPECT_FALSE(a.configuration_due(kT0));
  a.want_configuration(kT0 + 100ms);
  EXPECT_FALSE(a.configuration_due(kT0 + 99ms));
  EXPECT_TRUE(a.configuration_due(kT0 + 100ms));
  a.want_configure = false;  // the controller took it (a runner slot was free)
  EXPECT_FALSE(a.configuration_due(kT0 + 1s));
}

TEST(DeviceAgentSchedule, ThreeFailedAttemptsMakeItFailedAndRetriedAfter30s) {
  DeviceAgent a;
  a.want_configuration(kT0);
  TimePoint now = kT0;
  for (unsigned i = 1; i < kConfigureAttempts; ++i) {
    a.begin_attempt(now);
    EXPECT_EQ(a.attempts, i);
    EXPECT_FALSE(a.note_failed_attempt(now)) << "attempt " << i;
    EXPECT_EQ(a.not_before, now + kConfigureRetryDelay);
    now = a.not_before;
  }
  a.begin_attempt(now);
  EXPECT_TRUE(a.note_failed_attempt(now));
  EXPECT_EQ(a.not_before, now + kFailedRetryPeriod);
  EXPECT_EQ(a.attempts, 0U) << "the retry after the long wait starts a fresh count";
  EXPECT_TRUE(a.want_configure);
}

TEST(DeviceAgentSchedule, QuickCheckThatFoundTheConfigurationGoneDoesNotCount) {
  DeviceAgent a;
  a.want_configuration(kT0);
  a.force_full = true;
  a.begin_attempt(kT0);
  EXPECT_FALSE(a.force_full) << "the run took it";
  a.redo_at_once(kT0 + 5ms);
  EXPECT_EQ(a.attempts, 0U);
  EXPECT_TRUE(a.configuration_due(kT0 + 5ms));
}

TEST(DeviceAgentSchedule, ReplanStartsTheWholeWayAgain) {
  DeviceAgent a;
  a.started = true;
  a.attempts = 2;
  a.replan(kT0);
  EXPECT_FALSE(a.started);
  EXPECT_EQ(a.attempts, 0U);
  EXPECT_TRUE(a.configuration_due(kT0));
}

PlanStep write_step(std::uint16_t index, std::uint32_t value = 0) {
  PlanStep step;
  step.write.index = index;
  step.write.value = value;
  return step;
}

PlanStep step_of(StepKind kind) {
  PlanStep step;
  step.kind = kind;
  return step;
}

TEST(DeviceAgentPlan, Cia301_7_2_8_QuickCheckReadsSupervisionAndMappingsOnly) {
  ConfigPlan full;
  full.steps = {step_of(StepKind::nmt), write_step(0x1017, 100), write_step(0x6001, 4096),
                step_of(StepKind::tpdo_mapping), write_step(0x100C, 100), write_step(0x100D, 3),
                step_of(StepKind::store)};
  const ConfigPlan q = quick_plan(full);
  ASSERT_EQ(q.steps.size(), 5U);
  EXPECT_EQ(q.steps[0].kind, StepKind::nmt);
  EXPECT_EQ(q.steps[1].write.index, 0x1017);
  EXPECT_EQ(q.steps[2].kind, StepKind::tpdo_mapping);
  EXPECT_EQ(q.steps[3].write.index, 0x100C);
  EXPECT_EQ(q.steps[4].write.index, 0x100D);
}

TEST(DeviceAgentPlan, J1_2_2_GuardingFromTheFallbackOfARefusedHeartbeat) {
  ConfigPlan plan;
  PlanStep hb = write_step(0x1017, 100);
  plan.steps = {hb};
  EXPECT_EQ(guarding_fallback(plan).mode, Supervision::Mode::none) << "no fallback: nothing to guard with";
  hb.fallback = {write_step(0x100C, 200).write, write_step(0x100D, 3).write};
  plan.steps = {hb};
  const Supervision s = guarding_fallback(plan);
  EXPECT_EQ(s.mode, Supervision::Mode::guarding);
  EXPECT_EQ(s.guard_time, 200ms);
  EXPECT_EQ(s.life_time_factor, 3);
}

TEST(DeviceAgentPlan, Cia301_7_2_8_3_SupervisionGuardingFirstThenThePlansHeartbeat) {
  DeviceAgent a;
  EXPECT_EQ(a.supervision_wanted().mode, Supervision::Mode::none);
  a.cfg.heartbeat_ms = 250;
  EXPECT_EQ(a.supervision_wanted().producer_time, 250ms);
  a.plan = ConfigPlan{};
  a.plan->heartbeat = true;
  a.plan->heartbeat_ms = 100;
  EXPECT_EQ(a.supervision_wanted().mode, Supervision::Mode::heartbeat);
  EXPECT_EQ(a.supervision_wanted().producer_time, 100ms) << "the plan's, as it writes 0x1017";
  a.cfg.guarding = config::Guarding{};
  a.cfg.guarding->guard_time_ms = 300;
  a.cfg.guarding->life_time_factor = 2;
  const Supervision s = a.supervision_wanted();
  EXPECT_EQ(s.mode, Supervision::Mode::guarding);
  EXPECT_EQ(s.guard_time, 300ms);
  EXPECT_EQ(s.life_time_factor, 2);
}

TEST(DeviceAgentPlan, AfterAFailedQuickCheckTheFullPlanStoresAll) {
  DeviceAgent a;
  a.plan = ConfigPlan{};
  a.plan->steps = {write_step(0x1017, 100), write_step(0x6001, 4096)};
  a.quick = true;
  EXPECT_EQ(a.plan_to_run().steps.size(), 1U) << "the quick check";
  EXPECT_EQ(a.plan_to_run().store_policy, config::StorePolicy::on_change);
  a.quick = false;
  a.store_all = true;
  const ConfigPlan run = a.plan_to_run();
  EXPECT_EQ(run.steps.size(), 2U);
  EXPECT_EQ(run.store_policy, config::StorePolicy::always);
  EXPECT_FALSE(a.store_all) << "taken by that run";
  EXPECT_EQ(a.plan_to_run().store_policy, config::StorePolicy::on_change) << "a later restore stores what changed";
}

PlanRunResult failed_run(PlanRunErrc why) {
  PlanRunResult r;
  r.error = Error(Errc::kTimeout, "no answer", "node 20", make_error_code(why));
  return r;
}

TEST(DeviceAgentRun, Cia301_7_2_4_3_FailureKindRemembered) {
  DeviceAgent a;
  a.plan = ConfigPlan{};
  EXPECT_EQ(a.judge_run(failed_run(PlanRunErrc::sdo_timeout), kT0), RunVerdict::failed);
  EXPECT_TRUE(a.failed_unanswered) << "a silence: the device may come back on its own";
  EXPECT_EQ(a.judge_run(failed_run(PlanRunErrc::sdo_abort), kT0), RunVerdict::failed);
  EXPECT_FALSE(a.failed_unanswered) << "an answer, a refusal";
}

TEST(DeviceAgentRun, QuickCheckThatWroteMeansTheConfigurationWasLost) {
  DeviceAgent a;
  a.plan = ConfigPlan{};
  a.plan->fingerprint = "f1";
  a.want_configuration(kT0);
  a.quick = true;
  a.begin_attempt(kT0);
  PlanRunResult wrote;
  wrote.writes = 2;
  EXPECT_EQ(a.judge_run(wrote, kT0 + 40ms), RunVerdict::configuration_lost);
  EXPECT_TRUE(a.force_full);
  EXPECT_TRUE(a.store_all);
  EXPECT_TRUE(a.configuration_due(kT0 + 40ms)) << "the full plan at once";
  EXPECT_EQ(a.attempts, 0U) << "the check is no failed attempt";
  EXPECT_EQ(a.st.configurations, 0U);
  EXPECT_TRUE(a.st.fingerprint.empty()) << "not carried until the full plan ran";
}

TEST(DeviceAgentRun, J1_2_2_ConfiguredWithTheGuardingFallback) {
  DeviceAgent a;
  a.plan = ConfigPlan{};
  a.plan->fingerprint = "f2";
  PlanStep hb = write_step(0x1017, 100);
  hb.fallback = {write_step(0x100C, 200).write, write_step(0x100D, 3).write};
  a.plan->steps = {hb};
  PlanRunResult done;
  done.writes = 1;
  done.guarding_fallback = true;
  EXPECT_EQ(a.judge_run(done, kT0), RunVerdict::configured);
  EXPECT_EQ(a.st.configurations, 1U);
  EXPECT_EQ(a.supervision.mode, Supervision::Mode::guarding);
  EXPECT_EQ(a.st.fingerprint, "f2");
  PlanRunResult nothing_to_write;
  EXPECT_EQ(a.judge_run(nothing_to_write, kT0 + 1s), RunVerdict::configured);
  EXPECT_EQ(a.st.configurations, 1U) << "a run that changed nothing is no configuration";
}

DriftRecord drift(std::uint16_t index, std::uint8_t sub, const char* object, bool contested = false) {
  DriftRecord r;
  r.index = index;
  r.sub = sub;
  r.object = object;
  r.contested = contested;
  return r;
}

// Makes index:sub contested in the agent's RestoreGuard as a writer that
// keeps writing would: a drift past the restores the window allows.
void contest(DeviceAgent& a, std::uint16_t index, std::uint8_t sub) {
  for (unsigned i = 0; i <= RestoreLimits::kMaxRestores; ++i) (void)a.restore_guard.on_drift(index, sub, kT0 + 1s * i);
  ASSERT_TRUE(a.restore_guard.contested(index, sub));
}

TEST(DeviceAgentDrift, PlanClosesWhatItPutRightNotContestedNorWrittenMeanwhile) {
  DeviceAgent a;
  a.st.drift = {drift(0x1017, 0, "0x1017:00"), drift(0x6001, 0, "0x6001:00", true), drift(0x1800, 5, "0x1800:05")};
  a.note_drift_mid_plan(0x1800, 5);
  a.note_drift_mid_plan(0x1800, 5);  // once is enough
  EXPECT_EQ(a.drift_mid_plan.size(), 1U);
  EXPECT_EQ(a.close_restored_drift(), "0x1017:00");
  ASSERT_EQ(a.st.drift.size(), 2U);
  EXPECT_EQ(a.st.drift[0].object, "0x6001:00");
  EXPECT_EQ(a.st.drift[1].object, "0x1800:05");
  EXPECT_EQ(a.close_restored_drift(), "") << "nothing more to close";
}

TEST(DeviceAgentDrift, ContestedObjectsWriteLeftOutOfThePlan) {
  DeviceAgent a;
  ConfigPlan plan;
  plan.steps = {write_step(0x1017), write_step(0x6001)};
  PlanStep store;
  store.kind = StepKind::store;
  store.write.index = 0x6001;  // not a write: stays whatever it names
  plan.steps.push_back(store);
  a.leave_contested(plan);
  EXPECT_EQ(plan.steps.size(), 3U) << "nothing contested: the whole plan";
  contest(a, 0x6001, 0);
  a.leave_contested(plan);
  ASSERT_EQ(plan.steps.size(), 2U);
  EXPECT_EQ(plan.steps[0].write.index, 0x1017);
  EXPECT_EQ(plan.steps[1].kind, StepKind::store);
}

TEST(DeviceAgentDrift, AcknowledgementFreesContestedObjectsAndTheirCounts) {
  DeviceAgent a;
  EXPECT_FALSE(a.acknowledge_contested().has_value()) << "nothing contested: nothing to acknowledge";
  contest(a, 0x6001, 0);
  contest(a, 0x1017, 0);
  a.st.drift = {drift(0x6001, 0, "0x6001:00", true), drift(0x1017, 0, "0x1017:00", true), drift(0x6200, 0, "0x6200:00")};
  a.st.drift[0].restores = 3;
  EXPECT_EQ(a.acknowledge_contested(), std::optional<std::string>("0x6001:00, 0x1017:00"));
  EXPECT_FALSE(a.restore_guard.any_contested());
  EXPECT_FALSE(a.st.drift[0].contested);
  EXPECT_EQ(a.st.drift[0].restores, 0U);
  EXPECT_FALSE(a.acknowledge_contested().has_value()) << "acknowledged once";
}

TEST(DeviceAgentStart, Cia301_7_2_8_3_2_HeartbeatStampedBeforeTheStartTookIsNoNews) {
  DeviceAgent a;
  a.note_start_sent(kStartWallNs, kT0);
  // Read 300 ms late by a loaded gateway, stamped by the kernel 49 ms after
  // the start: sent before the device acted on it.
  EXPECT_TRUE(a.told_before_start(kStartWallNs + ns(kStartReaction) - 1, kT0 + 300ms));
  // Stamped after the start had time to act: the device's state now.
  EXPECT_FALSE(a.told_before_start(kStartWallNs + ns(kStartReaction) + 1, kT0 + 300ms));
}

TEST(DeviceAgentStart, Cia301_7_2_8_3_2_OnlyWithinTheStaleWindow) {
  DeviceAgent a;
  a.note_start_sent(kStartWallNs, kT0);
  // A wall clock stepped back by NTP makes every later stamp look early:
  // past the window a pre-operational heartbeat is news whatever its stamp.
  EXPECT_TRUE(a.told_before_start(kStartWallNs - ns(10s), kT0 + kStartStaleWindow));
  EXPECT_FALSE(a.told_before_start(kStartWallNs - ns(10s), kT0 + kStartStaleWindow + 1ms));
}

TEST(DeviceAgentStart, UnstampedFrameIsNewsExceptWithinACommandsSettle) {
  DeviceAgent a;
  a.note_start_sent(kStartWallNs, kT0);
  EXPECT_FALSE(a.told_before_start(0, kT0 + 10ms)) << "no stamp: nothing to judge it by";
  a.expect_pre_operational(kT0 + 20ms);
  EXPECT_TRUE(a.told_before_start(0, kT0 + 20ms + kCommandSettle - 1ms));
  EXPECT_FALSE(a.told_before_start(0, kT0 + 20ms + kCommandSettle));
}

TEST(DeviceAgentStart, NothingIsStaleBeforeAnyStart) {
  DeviceAgent a;
  EXPECT_FALSE(a.told_before_start(kStartWallNs, kT0));
  EXPECT_FALSE(a.take_start_resend(kT0));
}

TEST(DeviceAgentStart, Cia301_7_2_8_2_1_1_StartResentAtMostThreeTimesWithinTheWindow) {
  DeviceAgent a;
  a.note_start_sent(kStartWallNs, kT0);
  for (unsigned i = 1; i <= kStartResends; ++i) {
    EXPECT_TRUE(a.take_start_resend(kT0 + 100ms * i)) << "re-send " << i;
    EXPECT_EQ(a.start_resends(), i);
  }
  EXPECT_FALSE(a.take_start_resend(kT0 + 500ms)) << "past the re-sends: the whole plan";
  a.note_start_sent(kStartWallNs + ns(2s), kT0 + 2s);  // that plan's own start
  EXPECT_EQ(a.start_resends(), 0U);
  EXPECT_TRUE(a.take_start_resend(kT0 + 2s + 100ms));
  EXPECT_FALSE(a.take_start_resend(kT0 + 2s + kStartStaleWindow + 1ms)) << "past the window: the whole plan";
  EXPECT_EQ(a.since_start(kT0 + 2s + 300ms), 300ms);
}

// A started device whose start went out at kT0 (kernel stamps in kStartWallNs).
DeviceAgent started_agent() {
  DeviceAgent a;
  a.started = true;
  a.st.state = DeviceState::operational;
  a.note_start_sent(kStartWallNs, kT0);
  return a;
}

constexpr bool kRestart = true;
constexpr bool kRespect = false;
using canopen::NmtState;

TEST(DeviceAgentNmt, Cia301_7_2_8_3_2_NotOursToJudgeBeforeTheStartOrWhileAPlanRuns) {
  DeviceAgent a;
  EXPECT_EQ(a.judge_nmt(NmtState::pre_operational, 0, kT0 + 2s, kRestart), NmtVerdict::ignore) << "not started";
  a = started_agent();
  EXPECT_EQ(a.judge_nmt(NmtState::boot_up, 0, kT0 + 2s, kRestart), NmtVerdict::ignore)
      << "a boot-up is the supervisor's change of its own";
  EXPECT_EQ(a.judge_nmt(NmtState::operational, 0, kT0 + 2s, kRestart), NmtVerdict::ignore) << "what it should be";
}

TEST(DeviceAgentNmt, Cia301_7_2_8_3_2_PreOperationalSentBeforeTheStartTookIsStale) {
  DeviceAgent a = started_agent();
  EXPECT_EQ(a.judge_nmt(NmtState::pre_operational, kStartWallNs + ns(10ms), kT0 + 400ms, kRestart), NmtVerdict::stale);
  EXPECT_EQ(a.start_resends(), 0U) << "a stale state costs no re-send";
}

TEST(DeviceAgentNmt, OperatorsStopIsLeftAsAsked) {
  DeviceAgent a = started_agent();
  a.operator_hold = true;
  EXPECT_EQ(a.judge_nmt(NmtState::stopped, 0, kT0 + 2s, kRestart), NmtVerdict::operator_hold);
  EXPECT_EQ(a.judge_nmt(NmtState::pre_operational, 0, kT0 + 2s, kRestart), NmtVerdict::operator_hold);
}

TEST(DeviceAgentNmt, Cia301_7_2_8_3_2_StoppedByAnotherMasterRestartedOrRespectedPerPolicy) {
  DeviceAgent a = started_agent();
  EXPECT_EQ(a.judge_nmt(NmtState::stopped, 0, kT0 + 2s, kRestart), NmtVerdict::stopped_restart);
  EXPECT_EQ(a.judge_nmt(NmtState::stopped, 0, kT0 + 2s, kRespect), NmtVerdict::stopped_left);
  a.st.state = DeviceState::stopped;
  EXPECT_EQ(a.judge_nmt(NmtState::stopped, 0, kT0 + 2s, kRestart), NmtVerdict::ignore) << "known already";
  EXPECT_EQ(a.judge_nmt(NmtState::operational, 0, kT0 + 3s, kRestart), NmtVerdict::operational_again);
}

TEST(DeviceAgentNmt, Cia301_7_2_8_2_1_1_PreOperationalAfterTheStartResentThenReplanned) {
  DeviceAgent a = started_agent();
  EXPECT_EQ(a.judge_nmt(NmtState::pre_operational, 0, kT0 + 2s, kRespect), NmtVerdict::pre_operational_left);
  const std::int64_t late = kStartWallNs + ns(kStartReaction) + ns(1ms);  // sent after the start had acted
  for (unsigned i = 1; i <= kStartResends; ++i)
    EXPECT_EQ(a.judge_nmt(NmtState::pre_operational, late, kT0 + 100ms * i, kRestart), NmtVerdict::resend_start);
  EXPECT_EQ(a.judge_nmt(NmtState::pre_operational, late, kT0 + 500ms, kRestart), NmtVerdict::replan);
  DeviceAgent b = started_agent();
  EXPECT_EQ(b.judge_nmt(NmtState::pre_operational, 0, kT0 + kStartStaleWindow + 1ms, kRestart), NmtVerdict::replan)
      << "long after the start: someone put it back";
}

// ---- the identity check (buses without discovery) --------------------------

// Frames the agent's SDO client would send: taken and dropped.
struct NullSink final : can::FrameSink {
  bool send(const can::Frame&) noexcept override { return true; }
};

TEST(DeviceAgentIdentity, AWantedReadIsDueFromItsTimeOnAndNotWhileOneRuns) {
  DeviceAgent a;
  EXPECT_FALSE(a.identity_due(kT0));
  EXPECT_EQ(a.identity_wait(kT0), canopen::kNever);
  a.want_identity(kT0 + 500ms, false);
  EXPECT_FALSE(a.identity_due(kT0 + 499ms));
  EXPECT_EQ(a.identity_wait(kT0), kT0 + 500ms);
  EXPECT_EQ(a.identity_wait(kT0 + 2s), kT0 + 2s) << "overdue: look now";
  EXPECT_TRUE(a.identity_due(kT0 + 500ms));
  NullSink sink;
  canopen::SdoClient sdo(sink, 20, {});
  a.begin_identity();
  a.ident = std::make_unique<IdentityReader>(sdo);
  EXPECT_FALSE(a.identity_due(kT0 + 1s)) << "taken";
  a.want_identity(kT0 + 1s, false);  // asked again while the read runs
  EXPECT_FALSE(a.identity_due(kT0 + 2s)) << "one read at a time";
  EXPECT_EQ(a.identity_wait(kT0 + 2s), canopen::kNever);
  a.drop_identity();  // the interface went down
  EXPECT_FALSE(a.ident);
  EXPECT_FALSE(a.identity_due(kT0 + 3s)) << "asked again when the bus is back, not before";
}

TEST(DeviceAgentIdentity, ABootUpsAskIsKeptUntilTheReadIsJudged) {
  DeviceAgent a;
  a.want_identity(kT0, true);
  a.want_identity(kT0 + 500ms, false);  // a retry after a failed start of the read
  EXPECT_TRUE(a.take_identity_boot_up()) << "still the boot-up's read";
  EXPECT_FALSE(a.take_identity_boot_up()) << "forgotten once taken";
}

TEST(DeviceAgentIdentity, Cia301_7_5_2_35_TheConfiguredSerialOrNoneIsIdentified) {
  DeviceAgent a;
  a.cfg.serial = 0x1234;
  canopen::LssAddress id{};
  id.serial = 0x1234;
  EXPECT_EQ(a.judge_identity(std::nullopt), IdentityVerdict::unanswered);
  EXPECT_EQ(a.judge_identity(id), IdentityVerdict::identified);
  id.serial = 0x9999;
  EXPECT_EQ(a.judge_identity(id), IdentityVerdict::other_serial) << "another device at the node: not configured";
  a.cfg.serial = 0;
  EXPECT_EQ(a.judge_identity(id), IdentityVerdict::identified) << "no serial configured: any device of the node";
}

// ---- the standby's view ---------------------------------------------------------

// A configured device the standby knows by its serial only (not placed yet).
DeviceAgent standby_agent() {
  DeviceAgent a;
  a.cfg.serial = 2500;
  a.cfg.vendor = 0x182;
  a.st.state = DeviceState::expected;
  return a;
}

TEST(DeviceAgentStandby, Cia301_7_2_4_3_3_TheMastersIdentityReadPlacesTheDevice) {
  DeviceAgent a = standby_agent();
  canopen::LssAddress id{};
  id.vendor = 0x182;
  id.serial = 2500;
  EXPECT_TRUE(a.note_identity_heard(id, 20));
  EXPECT_EQ(a.st.node_id, 20);
  EXPECT_EQ(a.st.identity.serial, 2500U);
  EXPECT_FALSE(a.note_identity_heard(id, 20)) << "already there: no news";
  a.followed = true;
  EXPECT_TRUE(a.note_identity_heard(id, 21)) << "moved (the master gave it another node-ID)";
  EXPECT_FALSE(a.followed) << "announced again at its new node-ID";
  id.serial = 2501;
  EXPECT_FALSE(a.note_identity_heard(id, 22)) << "another device's serial";
  id.serial = 2500;
  id.vendor = 0x69666D;
  EXPECT_FALSE(a.note_identity_heard(id, 22)) << "the serial of another vendor's device";
  a.in_config = false;
  id.vendor = 0x182;
  EXPECT_FALSE(a.note_identity_heard(id, 22)) << "an unknown device is never placed so";
}

TEST(DeviceAgentStandby, FollowedOnlyOncePlacedAndHeardOperational) {
  DeviceAgent a = standby_agent();
  EXPECT_FALSE(a.to_follow()) << "not placed";
  a.st.node_id = 20;
  EXPECT_FALSE(a.to_follow()) << "not heard operational";
  EXPECT_TRUE(a.note_heard_state(true));
  EXPECT_FALSE(a.note_heard_state(true)) << "the same state again: no news";
  EXPECT_TRUE(a.to_follow());
  a.followed = true;
  EXPECT_FALSE(a.to_follow()) << "announced once";
}

TEST(DeviceAgentStandby, Cia301_7_2_8_3_2_TheStatusIsOperationalWhileFollowedAndHeardSo) {
  DeviceAgent a = standby_agent();
  a.st.node_id = 20;
  EXPECT_EQ(a.as_the_bus_says().state, DeviceState::expected);
  (void)a.note_heard_state(true);
  EXPECT_EQ(a.as_the_bus_says().state, DeviceState::expected) << "not followed yet";
  a.followed = true;
  EXPECT_EQ(a.as_the_bus_says().state, DeviceState::operational);
  EXPECT_EQ(a.as_the_bus_says().nmt, canopen::NmtState::operational);
  EXPECT_EQ(a.st.state, DeviceState::expected) << "the record itself is not changed";
  (void)a.note_heard_state(false);  // its heartbeat says pre-operational now
  EXPECT_EQ(a.as_the_bus_says().state, DeviceState::expected);
}

// ---- discovery's reports (CiA 305: identified, at its node-ID or not) ---------

// Discovery's `identified` for serial 2500 of vendor 0x182 at `node`.
DiscoveryEvent identified_at(std::uint8_t node, std::uint8_t target) {
  DiscoveryEvent e;
  e.kind = DiscoveryEventKind::identified;
  e.node_id = node;
  e.target_node_id = target;
  e.at_target = node == target;
  e.identity.vendor = 0x182;
  e.identity.serial = 2500;
  return e;
}

// A configured device at node 20, started, online and operational.
DeviceAgent running_agent() {
  DeviceAgent a;
  a.st.node_id = 20;
  a.st.identity.vendor = 0x182;
  a.st.identity.serial = 2500;
  a.st.online = true;
  a.st.state = DeviceState::operational;
  a.started = true;
  return a;
}

TEST(DeviceAgentDiscovery, Cia305_NotAtItsNodeIdItIsMovedUnlessTheStateFileIsHeld) {
  const DeviceAgent a = running_agent();
  EXPECT_EQ(a.judge_identified(identified_at(127, 20), false), IdentifiedVerdict::moving);
  EXPECT_EQ(a.judge_identified(identified_at(127, 20), true), IdentifiedVerdict::held_in_place);
  EXPECT_EQ(a.judge_identified(identified_at(127, 0), true), IdentifiedVerdict::moving)
      << "no target: discovery leaves it alone, nothing is held";
}

TEST(DeviceAgentDiscovery, Cia305_TheSameDeviceRunningFineIsLeftAloneABootUpIsNot) {
  DeviceAgent a = running_agent();
  EXPECT_EQ(a.judge_identified(identified_at(20, 20), false), IdentifiedVerdict::running_fine);
  DiscoveryEvent boot = identified_at(20, 20);
  boot.boot_up = true;
  EXPECT_EQ(a.judge_identified(boot, false), IdentifiedVerdict::reconfigure) << "it restarted: configured again";
  DiscoveryEvent other = identified_at(20, 20);
  other.identity.serial = 2501;  // a replacement part at its place
  EXPECT_EQ(a.judge_identified(other, false), IdentifiedVerdict::reconfigure);
  a.st.online = false;
  EXPECT_EQ(a.judge_identified(identified_at(20, 20), false), IdentifiedVerdict::reconfigure) << "was offline";
}

TEST(DeviceAgentDiscovery, ADevicePlannedAlreadyIsOnItsWayNotPlannedTwice) {
  DeviceAgent a = running_agent();
  a.started = false;
  a.st.state = DeviceState::identified;
  a.want_configuration(kT0 + 5s);  // the reboot fallback's plan, waiting
  EXPECT_EQ(a.judge_identified(identified_at(20, 20), false), IdentifiedVerdict::reconfigure)
      << "no description chosen yet: nothing to configure with";
  const device::DeviceDescription description;
  a.description = &description;
  EXPECT_EQ(a.judge_identified(identified_at(20, 20), false), IdentifiedVerdict::on_its_way);
}

TEST(DeviceAgentDiscovery, AnUnknownDevicesEntryIsKnownByVendorAndSerial) {
  DeviceAgent u;
  u.in_config = false;
  u.st.identity.vendor = 0x182;
  u.st.identity.serial = 2500;
  EXPECT_TRUE(u.is_unknown(identified_at(20, 20).identity));
  canopen::LssAddress other = identified_at(20, 20).identity;
  other.vendor = 0x69666D;
  EXPECT_FALSE(u.is_unknown(other)) << "the same serial of another vendor";
  EXPECT_FALSE(running_agent().is_unknown(identified_at(20, 20).identity)) << "a configured device";
}


// ---- configuration drift: the restore decision (docs/reliability.md) ------

// A device the gateway can configure: a description and a family chosen.
struct RestorableAgent {
  device::DeviceDescription description;
  DeviceAgent a;
  RestorableAgent() {
    a.description = &description;
    a.profile = device::FamilyProfile{};
    a.st.drift = {drift(0x6001, 0, "0x6001:00")};
  }
  DriftRecord& record() { return a.st.drift.front(); }
  void plan_ran() {  // the controller took the wanted plan and it ended
    a.want_configure = false;
    a.force_full = false;
  }
};

TEST(DeviceAgentRestore, ThreeRestoresWithTheirBackoffThenContestedThenHeld) {
  RestorableAgent t;
  RestoreDecision d = t.a.judge_restore(t.record(), kT0);
  EXPECT_EQ(d.verdict, RestoreVerdict::restore);
  EXPECT_EQ(d.not_before, kT0) << "the first restore at once";
  EXPECT_EQ(t.record().restores, 1U);
  ASSERT_TRUE(t.a.want_restore(d.not_before));
  EXPECT_TRUE(t.a.force_full);
  EXPECT_TRUE(t.a.configuration_due(kT0));
  EXPECT_EQ(t.a.judge_restore(t.record(), kT0 + 1s).verdict, RestoreVerdict::on_its_way);
  EXPECT_EQ(t.record().restores, 1U) << "a restore on its way already is not counted again";
  t.plan_ran();
  d = t.a.judge_restore(t.record(), kT0 + 2s);
  EXPECT_EQ(d.verdict, RestoreVerdict::restore);
  EXPECT_EQ(d.not_before, kT0 + 7s) << "the second after 5 s";
  EXPECT_EQ(t.record().restores, 2U);
  d = t.a.judge_restore(t.record(), kT0 + 10s);
  EXPECT_EQ(d.not_before, kT0 + 30s) << "the third after 20 s";
  EXPECT_EQ(t.a.judge_restore(t.record(), kT0 + 40s).verdict, RestoreVerdict::contested_now);
  EXPECT_TRUE(t.record().contested);
  EXPECT_EQ(t.a.judge_restore(t.record(), kT0 + 41s).verdict, RestoreVerdict::held) << "said once";
  t.a.want_configure = true;  // another object's restore wanted meanwhile
  t.a.force_full = true;
  EXPECT_EQ(t.a.judge_restore(t.record(), kT0 + 42s).verdict, RestoreVerdict::held)
      << "a contested object is held whatever else is on its way";
}

TEST(DeviceAgentRestore, AWriteWhileAPlanRunsStaysOpenForAfterThePlan) {
  RestorableAgent t;
  NullSink sink;
  canopen::SdoClient sdo(sink, 20, {});
  t.a.runner = std::make_unique<PlanRunner>(sink, sdo, ConfigPlan{});
  EXPECT_EQ(t.a.judge_restore(t.record(), kT0).verdict, RestoreVerdict::after_the_plan);
  EXPECT_EQ(t.a.drift_mid_plan, std::vector<std::uint32_t>{object_number(0x6001, 0)});
  EXPECT_EQ(t.record().restores, 0U) << "not counted: the plan may have written it first";
  EXPECT_FALSE(t.a.want_restore(kT0)) << "the plan on its way rewrites what differs";
  t.a.command = DeviceCommand{};  // the runner runs a command, not the configuration
  EXPECT_EQ(t.a.judge_restore(t.record(), kT0).verdict, RestoreVerdict::restore);
  EXPECT_EQ(t.record().restores, 1U);
}

TEST(DeviceAgentRestore, NoneWithoutADescriptionNorWhileAnOperatorHoldsTheDevice) {
  RestorableAgent t;
  t.a.description = nullptr;
  EXPECT_FALSE(t.a.want_restore(kT0)) << "nothing to configure with";
  t.a.description = &t.description;
  t.a.operator_hold = true;  // a client's NMT stop: the restore waits for its start
  EXPECT_FALSE(t.a.want_restore(kT0));
  EXPECT_FALSE(t.a.want_configure);
  EXPECT_FALSE(t.a.force_full);
  t.a.operator_hold = false;
  ASSERT_TRUE(t.a.want_restore(kT0 + 5s));
  EXPECT_FALSE(t.a.configuration_due(kT0 + 4s)) << "the guard's backoff";
  EXPECT_TRUE(t.a.configuration_due(kT0 + 5s));
}

}  // namespace
}  // namespace cobridge::bus
