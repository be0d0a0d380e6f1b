// DeviceAgent: one device of a bus as its controller keeps it (a configured
// device, or an unknown one discovery reported): what is known of it, the
// plan run on it, and the decisions that need nothing but the device's own
// record and the time: when its configuration is due again after a failure,
// what its identity read and discovery's report of it mean, what a standby
// shows of it, and what a heartbeat after the gateway's NMT start means.
//
// The bus controller (bus_manager_*.cpp) does the sending, logging and
// status around these decisions; the agent reads no clock (`now` and the
// frames' kernel stamps are passed in) and owns no socket.
//
// Thread: the bus's control thread only.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "bus/config_plan.hpp"
#include "bus/device_command.hpp"
#include "bus/device_status.hpp"
#include "bus/discovery.hpp"
#include "bus/identity_reader.hpp"
#include "bus/log_budget.hpp"
#include "bus/plan_runner.hpp"
#include "bus/restore_guard.hpp"
#include "bus/supervisor.hpp"
#include "canopen/clock.hpp"
#include "canopen/sdo_client.hpp"
#include "config/config.hpp"
#include "device/eds.hpp"
#include "device/family_profile.hpp"

namespace cobridge::bus {

// Plan runs before the device is `failed`, and the waits between them.
constexpr unsigned kConfigureAttempts = 3;
constexpr std::chrono::milliseconds kConfigureRetryDelay{500};
constexpr std::chrono::milliseconds kFailedRetryPeriod{30000};  // a failed device is tried again this often
// After a command that passed through pre-operational, a heartbeat sent
// before the device got NMT start may still arrive: not a surprise reset.
constexpr std::chrono::milliseconds kCommandSettle{500};
// After a plan's NMT start: a heartbeat stamped by the kernel before the
// start was sent plus this (the frame on the wire, the device acting on it)
// tells the state before the start, whenever a loaded gateway reads it.
constexpr std::chrono::milliseconds kStartReaction{50};
// ... judged so only this long after the start: a heartbeat read later is
// no longer one the gateway was slow to read, and a wall clock stepped back
// (NTP) in between cannot hide a device put back to pre-operational.
constexpr std::chrono::milliseconds kStartStaleWindow{1000};
// Pre-operational heard within that window but after kStartReaction: a device
// slow to act on the start (its heartbeat producer ahead of its NMT state
// machine) or one that missed it. Its configuration was verified and stored
// just before, so the start is sent again, at most this often, instead of
// the whole plan: a plan per late heartbeat never ends on a slow device.
constexpr unsigned kStartResends = 3;

// The objects whose agreement says "this device still carries its
// configuration": supervision and the PDO mappings, read (and compared)
// between pre-operational and nothing else. No store step.
[[nodiscard]] ConfigPlan quick_plan(const ConfigPlan& full);
// Node guarding from a plan's fallback writes of 0x100C/0x100D, for a device
// that refused the heartbeat producer 0x1017 (J§1.2.2); none when the plan
// has no such fallback.
[[nodiscard]] Supervision guarding_fallback(const ConfigPlan& plan);

// What the gateway does about an NMT state a started device's heartbeat (or
// guarding reply) tells (CiA 301 §7.2.8.3.2), DeviceAgent::judge_nmt.
enum class NmtVerdict : std::uint8_t {
  ignore,               // nothing new, or the device is not ours to judge now (not started, a plan runs)
  stale,                // sent before the device took our start, read after it: forget it
  operator_hold,        // a client's NMT command stopped it: `stopped`, left so
  operational_again,    // back to operational after being stopped
  stopped_left,         // another NMT master stopped it; foreign_nmt = respect
  stopped_restart,      // ... foreign_nmt = restart: start it again
  pre_operational_left, // back in pre-operational; foreign_nmt = respect
  resend_start,         // pre-operational soon after our start: the start once more (counted)
  replan,               // pre-operational otherwise: check, configure and start it again
};

// What the identity (0x1018, CiA 301 §7.5.2.35) read before configuring a
// device on a bus without discovery means, DeviceAgent::judge_identity.
enum class IdentityVerdict : std::uint8_t {
  unanswered,    // no identity read: asked again after the discovery period
  other_serial,  // another serial than the configured one: not configured (`failed`), asked again
  identified,    // the configured device (or no serial configured): configure it
};

// What discovery's `identified` (CiA 305: the device found, its identity
// read) means for a configured device, DeviceAgent::judge_identified.
enum class IdentifiedVerdict : std::uint8_t {
  held_in_place,  // not at its node-ID, and no node-ID moves while the state file is held: it waits there
  moving,         // not at its node-ID: discovery moves it and reports it again at the target
  running_fine,   // the same device, started, online and operational where it was: nothing to do
  on_its_way,     // the same device, already planned or configuring (the reboot fallback came first)
  reconfigure,    // anything else: remembered at its node-ID, configured from the start
};

// What a finished plan run (configuration, not a command) means for the
// device, DeviceAgent::judge_run.
enum class RunVerdict : std::uint8_t {
  failed,              // tried again after a wait (note_failed_attempt)
  configuration_lost,  // the quick check found values the stored configuration does not have: the full plan, at once
  configured,          // verified (and stored): the NMT start is next
};

// What a client's drift of an object the plan sets means under
// on_config_drift = "restore", DeviceAgent::judge_restore.
enum class RestoreVerdict : std::uint8_t {
  after_the_plan,  // a plan runs: it may have written the object before the client; it stays open after it
  on_its_way,      // the full plan is wanted already (another object's restore): nothing more
  restore,         // the full plan from RestoreDecision::not_before (the guard's backoff)
  contested_now,   // the writer outlasted the restores: contested from now on, said once
  held,            // contested already: written no more until acknowledged
};
struct RestoreDecision {
  RestoreVerdict verdict = RestoreVerdict::restore;
  canopen::TimePoint not_before{};  // restore only
};

struct DeviceAgent {
  config::Device cfg;
  bool in_config = true;  // false: an unknown device, shown in the status only
  DeviceStatus st;
  const device::DeviceDescription* description = nullptr;
  std::optional<device::FamilyProfile> profile;
  Supervision supervision;
  std::optional<ConfigPlan> plan;
  std::unique_ptr<canopen::SdoClient> sdo;  // the runner's; re-addressed per run
  std::unique_ptr<PlanRunner> runner;
  std::optional<DeviceCommand> command;  // the runner runs this command, not the configuration
  bool quick = false;       // the running plan is the fingerprint check
  bool force_full = false;  // the next run is the full plan
  bool store_all = false;   // ... and stores all it names: the quick check already wrote some
  bool want_configure = false;  // waiting for a runner slot
  bool started = false;         // NMT start sent after a successful plan
  bool followed = false;        // standby: its decode plan is announced to the outputs
  bool heard_operational = false;  // standby: its last heartbeat said operational
  bool failed_unanswered = false;  // the last failure was a silence (timeout, nothing sent)
  bool operator_hold = false;      // stopped / pre-operational by a client's NMT command: left so
  unsigned attempts = 0;
  canopen::TimePoint not_before{};  // retry back-off
  canopen::TimePoint configure_started{};
  canopen::TimePoint boot_up_at = canopen::kNever;  // last boot-up, to report how long the way back took
  LogBudget emcy_log;             // EMCY log lines (the outputs get every EMCY)
  RestoreGuard restore_guard;     // drift restores per object: backoff, contested
  // Drifted objects (index << 8 | sub) a client wrote while a plan ran:
  // that plan may have written them before the client did, so they stay
  // open after it and get a restore of their own.
  std::vector<std::uint32_t> drift_mid_plan;
  // Buses without discovery: the identity check before configuring (its
  // reader runs while it is set).
  std::unique_ptr<IdentityReader> ident;

  // ---- the configuration's schedule ----------------------------------------

  // A plan is wanted from `when` on, its attempts counted afresh.
  void want_configuration(canopen::TimePoint when) noexcept;
  // Not started any more (a boot-up, a reset, a new identity): the whole
  // way from pre-operational again, from `when` on.
  void replan(canopen::TimePoint when) noexcept {
    started = false;
    want_configuration(when);
  }
  // A plan may start now: wanted, its time come, and nothing else running
  // on the device (a plan, a command, the identity check).
  [[nodiscard]] bool configuration_due(canopen::TimePoint now) const noexcept;
  // A plan run starts (counted as an attempt).
  void begin_attempt(canopen::TimePoint now) noexcept;
  // A plan that could not start, or whose NMT start could not be sent:
  // wanted again after the short delay, the attempt counted.
  void retry_soon(canopen::TimePoint now) noexcept;
  // A run that does not count: the quick check found the configuration
  // gone, and the full plan follows at once.
  void redo_at_once(canopen::TimePoint now) noexcept;
  // A failed run: wanted again after the short delay, or, its attempts
  // used up, after kFailedRetryPeriod with a fresh count. True when they
  // were used up (the device is then `failed`).
  [[nodiscard]] bool note_failed_attempt(canopen::TimePoint now) noexcept;

  // A plan run ended with `outcome`: the record follows it (the failure's
  // kind, the full plan after a lost configuration, the count of
  // configurations, node guarding when the device refused the heartbeat
  // (J§1.2.2), the fingerprint now carried).
  [[nodiscard]] RunVerdict judge_run(const PlanRunResult& outcome, canopen::TimePoint now);
  // What this run executes: the quick check or the full plan, less the
  // contested objects' writes, storing all it names after a failed quick
  // check (store_all, taken).
  [[nodiscard]] ConfigPlan plan_to_run();
  // The supervision the configuration asks for: node guarding when it sets
  // a guard time and life time factor, else the heartbeat the plan (or the
  // configuration) sets the producer to; none otherwise.
  [[nodiscard]] Supervision supervision_wanted() const;

  // ---- the identity check (buses without discovery) ------------------------

  // The identity is to be read from `when` on; `boot_up`: because the device
  // rebooted (kept until the read is judged).
  void want_identity(canopen::TimePoint when, bool boot_up) noexcept;
  // A read may start now: wanted, its time come, nothing running on the device.
  [[nodiscard]] bool identity_due(canopen::TimePoint now) const noexcept;
  // When the controller must look again for a wanted read not started yet
  // (kNever: none wanted, or one runs).
  [[nodiscard]] canopen::TimePoint identity_wait(canopen::TimePoint now) const noexcept;
  // A read starts (its reader in `ident`): no longer wanted.
  void begin_identity() noexcept { ident_wanted_ = false; }
  // The bus went away: the read running, and any wanted, are dropped (asked
  // again when the bus is back).
  void drop_identity() noexcept;
  // The identity read (none: unanswered) against the configured serial.
  [[nodiscard]] IdentityVerdict judge_identity(const std::optional<canopen::LssAddress>& identity) const noexcept;
  // Whether a boot-up asked for the read just judged (then forgotten).
  [[nodiscard]] bool take_identity_boot_up() noexcept { return std::exchange(ident_boot_up_, false); }

  // ---- discovery's reports (bus/discovery.hpp) -------------------------------

  // An unknown device's entry (shown in the status only) of this identity.
  [[nodiscard]] bool is_unknown(const canopen::LssAddress& id) const noexcept {
    return !in_config && st.identity.serial == id.serial && st.identity.vendor == id.vendor;
  }
  // Discovery identified this configured device: `e` (kind identified) says
  // where it is and where it must be; `state_held`: the state file is held
  // (unreadable, kept for the operator), so no node-ID moves.
  [[nodiscard]] IdentifiedVerdict judge_identified(const DiscoveryEvent& e, bool state_held) const noexcept;

  // ---- the standby's view (a hot-standby pair: it hears, never asks) ------

  // Its heartbeat said operational or not; true when that is news.
  bool note_heard_state(bool operational) noexcept;
  // The master read identity `id` from `node` (0x1018 through SDO, CiA 301
  // §7.2.4.3.3): when it is this configured device's serial (and vendor, if
  // configured) at another node-ID, the device is at `node` now and its
  // outputs are announced again. True when it moved.
  bool note_identity_heard(const canopen::LssAddress& id, std::uint8_t node) noexcept;
  // Its outputs may be announced as its configuration maps them: configured,
  // placed, heard operational, and not announced yet.
  [[nodiscard]] bool to_follow() const noexcept {
    return !followed && in_config && st.node_id != 0 && heard_operational;
  }
  // The status a standby shows: operational while it is followed and heard
  // so (the master configured it), else what the record says.
  [[nodiscard]] DeviceStatus as_the_bus_says() const;

  // ---- configuration drift (bus/config_drift.hpp, bus/restore_guard.hpp) ----

  // A client wrote index:sub while this device's plan ran: the plan may
  // have written it before the client did, so it stays open after the plan.
  void note_drift_mid_plan(std::uint16_t index, std::uint8_t sub);
  // After a successful plan: the drift it put right is closed; contested
  // objects and those written while it ran stay open. Returns the objects
  // closed ("0x6200:00, ..."; empty: none).
  [[nodiscard]] std::string close_restored_drift();
  // The write steps of contested objects taken out of a plan about to run.
  void leave_contested(ConfigPlan& to_run) const;
  // The client's write of open record `r` differs from the configuration
  // and the policy restores it: the plan running (if any), a restore wanted
  // already, or the RestoreGuard's count decides; `r` takes the count and
  // the contest.
  [[nodiscard]] RestoreDecision judge_restore(DriftRecord& r, canopen::TimePoint now);
  // The full plan for a restore, wanted from `when` on. False when none is
  // wanted: a plan is on its way (it rewrites what differs), the device has
  // no description, or a client's NMT command holds it (the restore waits
  // for the client's start).
  [[nodiscard]] bool want_restore(canopen::TimePoint when) noexcept;
  // An operator's acknowledgement: contested objects may be written again,
  // their restores counted afresh. Returns the objects it freed (nothing:
  // none was contested).
  [[nodiscard]] std::optional<std::string> acknowledge_contested();

  // ---- the NMT start (CiA 301 §7.2.8.3.2: the heartbeat tells the state) ----

  // Our NMT start went out: `wall_ns` the realtime (as the frames' kernel
  // stamps), `now` the steady time.
  void note_start_sent(std::int64_t wall_ns, canopen::TimePoint now) noexcept;
  // A command put the device through pre-operational: a heartbeat saying so
  // within kCommandSettle is no news.
  void expect_pre_operational(canopen::TimePoint now) noexcept { preop_expected_until_ = now + kCommandSettle; }
  // A state heard in a frame stamped `frame_ns` (0: no stamp) at `now`
  // tells what the device was before our last start (or a command), not
  // what it is now.
  [[nodiscard]] bool told_before_start(std::int64_t frame_ns, canopen::TimePoint now) const noexcept;
  // Pre-operational heard after the start had time to act: true when the
  // start may be sent once more (counted), false when the whole plan is due.
  [[nodiscard]] bool take_start_resend(canopen::TimePoint now) noexcept;
  // The NMT state `nmt` heard in a frame stamped `frame_ns` at `now`, with
  // the bus's foreign_nmt policy (`restart`: true). A resend_start verdict
  // counts the re-send.
  [[nodiscard]] NmtVerdict judge_nmt(canopen::NmtState nmt, std::int64_t frame_ns, canopen::TimePoint now,
                                     bool restart) noexcept;
  [[nodiscard]] unsigned start_resends() const noexcept { return start_resends_; }
  [[nodiscard]] canopen::Duration since_start(canopen::TimePoint now) const noexcept { return now - start_sent_at_; }

 private:
  canopen::TimePoint preop_expected_until_{};  // see kCommandSettle
  std::int64_t start_sent_ns_ = 0;             // realtime of our last NMT start (kStartReaction)
  canopen::TimePoint start_sent_at_{};         // ... and steady time (kStartStaleWindow)
  unsigned start_resends_ = 0;                 // since that start (kStartResends)
  bool ident_wanted_ = false;                  // an identity read waits for ident_at_
  bool ident_boot_up_ = false;                 // ... asked by a boot-up
  canopen::TimePoint ident_at_{};
};

}  // namespace cobridge::bus
