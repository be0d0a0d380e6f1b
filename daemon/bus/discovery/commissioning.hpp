// Commissioning orchestration: moves the identified devices to the node-IDs
// node-ID assignment decided, as jobs of LSS, NMT and SDO tasks run one at a
// time (the LSS channel serves one operation at a time).
//
// Commissioning (policy automatic; manual only after request(); never when
// off, where discovery only listens and reads identities by SDO upload of
// 0x1018: no LSS, no NMT, no SDO download; with the bus's `discovery = false`
// it sends nothing at all). Probes and commissioning never overlap: probes
// wait while commissioning runs and vice versa.
//   * wrong node-ID (a move job): LSS switch selective (identity from the
//     probe), configure node-ID, store, switch global waiting, NMT
//     reset-communication to the old node-ID, wait for the boot-up on the new
//     one. No LSS answer (ifm, whose LSS is undocumented) -> SDO fallback
//     through canopen::SdoClient: node-ID object (ifm 0x3000 = id - 1,
//     Novotechnik 0x2000 = id), 'save' to 0x1010, NMT reset node.
//   * clash (a clash job, clash_resolution.cpp): (a) switch selective for
//     each clashing device whose identity is known (serials from the probe;
//     vendor/product from the probe, else from the config's vendor/product or
//     its model's; revision from the probe, every one it saw tried in turn,
//     else found by Slowscan over [0, 0xFFFFFFFF]); (b) Slowscan over the
//     serial range for pre-Fastscan devices (Novotechnik rotary, vendor 0x182
//     products 0x0BE0/0x0BF3/0x0BBD/0x0BCD/0x0BE1); (c) otherwise every
//     device is made non-configured (switch global configuration, configure
//     node-ID FFh, not stored, switch global waiting, NMT reset-communication
//     all), then found one by one with Fastscan, and the pre-Fastscan ones of
//     the clash with Slowscan; devices known before keep their node-IDs. Then
//     NMT reset-communication and wait for boot-ups. The clash is resolved
//     (clash_resolved) only when the probe of the clash node that follows
//     finds one device or none there; if several still answer, the next
//     strategy runs: first (a)+(b)+(c) for what is left, then (b) for every
//     pre-Fastscan product seen + (c) for the rest, then (c) for everyone;
//     after that a problem says it could not be resolved.
//   * non-configured devices (FFh; a non-configured job after each full
//     probe) are found by Fastscan (only CiA 305 V3 slaves answer; the
//     searches of FastscanSearch), assigned and stored; when identify
//     non-configured is answered but Fastscan finds nobody, Slowscan over the
//     pre-Fastscan products looks for them (devices found that hold a node-ID
//     are left). See lss_outcomes.cpp.
//   * nobody left behind: a device whose configure node-ID or
//     switch selective fails is tried again with a doubling wait (1 s ... 30
//     s, CommissionRetries) until it is commissioned; each failure is a
//     `retry` event with its cause. A device that failed in a Fastscan loop
//     ends that loop (it would be found first again); its retry comes back.
// Each step is timed (Report::timing).
//
// Thread: the bus's control thread (the bus manager's): no threads, no clock
// reads; `now` is passed in. on_*frame() do not allocate.
#pragma once

#include "can/frame_sink.hpp"
#include "canopen/lss_master.hpp"
#include "canopen/sdo_client.hpp"
#include "bus/discovery/commission_retries.hpp"
#include "bus/discovery/decisions.hpp"
#include "bus/discovery/fastscan_search.hpp"
#include "bus/discovery/identity_probe.hpp"
#include "bus/discovery/lss_task.hpp"
#include "bus/discovery/report.hpp"

#include <bitset>
#include <deque>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace cobridge::bus::discovery {

struct Job {
  enum class Kind : std::uint8_t { move, clash, non_configured } kind;
  std::uint8_t node = 0;
  friend bool operator==(const Job&, const Job&) = default;
};

class Commissioning {
 public:
  Commissioning(can::FrameSink& sink, const BusSettings& settings, Decisions& decisions, IdentityProbe& probe,
                Report& report, canopen::LssMasterConfig lss_config);

  // Queued unless the policy is off; a job already queued is not doubled.
  void queue(Job j);
  // `cobridge commission` (manual policy): run what is queued, and search FFh.
  void request();
  // Whether jobs may start now (the policy; manual: after request()).
  [[nodiscard]] bool may_commission() const noexcept;
  // Something other than the FFh search is held back by the manual policy.
  [[nodiscard]] bool pending() const noexcept;
  // LSS/NMT work that may reset configured devices is under way.
  [[nodiscard]] bool resetting() const noexcept;
  [[nodiscard]] bool idle() const noexcept { return !current_ && tasks_.empty(); }
  // No reset of ours is recent: two boot-ups from one node-ID are a clash.
  [[nodiscard]] bool quiet(canopen::TimePoint now) const noexcept {
    return idle() && now >= expected_bootups_until_;
  }
  // A job is about node `n`: the periodic probe leaves it alone.
  [[nodiscard]] bool busy(std::uint8_t n) const noexcept { return work_[n].busy; }

  bool on_lss_frame(const can::Frame& f, canopen::TimePoint now) noexcept { return lss_.on_frame(f, now); }
  bool on_sdo_frame(const can::Frame& f, canopen::TimePoint now) noexcept {
    return sdo_ && sdo_->on_frame(f, now);
  }
  // A probe found `a` at the node-ID it must have: no more retries for it.
  void at_target(const LssAddress& a);
  // Boot-ups seen: the moves waiting for them are done (commissioned).
  void on_bootups(const std::bitset<128>& booted, canopen::TimePoint now);

  // Sends what is queued, collects the LSS result; true on progress.
  bool poll_lss(canopen::TimePoint now);
  // Runs the tasks; starts the next job unless `probing`. True on progress.
  bool drive(canopen::TimePoint now, bool probing);
  [[nodiscard]] canopen::TimePoint next_deadline(canopen::TimePoint now);

  // Clash bookkeeping (clash_resolution.cpp), told by the probe's results:
  // node `n` holds one device or none now.
  void clash_settled(std::uint8_t n);
  // Several devices still answer at `n` (`count` seen): the next strategy.
  void clash_persists(std::uint8_t n, std::uint32_t count);

 private:
  // A job being run, with the bookkeeping its procedures share.
  struct JobRun {
    Job job{};
    canopen::TimePoint started{};
    std::string device;
    std::set<std::uint32_t> serials;  // seen at the clash node
    std::set<std::uint32_t> handled;  // moved or deliberately left
    std::vector<LssAddress> found;    // found by Fastscan in (c)
    std::vector<std::pair<LssAddress, std::uint8_t>> known;  // (c): identity -> node to restore
    bool moved_any = false;
    bool slowscanned = false;  // non-configured job: the Slowscan fallback ran
    std::set<std::uint32_t> failed;  // serials whose commissioning failed in this run
  };
  struct NodeWork {
    // The next clash strategy to try here (see expand_clash); reset once
    // the node holds one device or none.
    std::uint8_t clash_strategy = 0;
    // A resolution ran: the next finished probe of this node decides whether
    // it worked (clash_resolved) or the next strategy must run.
    bool clash_verify = false;
    std::uint32_t clash_count = 0;  // devices seen when the resolution started
    bool clash_moved_any = false;
    bool busy = false;              // a commissioning job is about this node
  };
  struct BootWait {
    Ctx ctx;
    canopen::TimePoint registered{};
    bool seen = false;
  };

  // commissioning.cpp: jobs and the task interpreter
  void expand(const Job& j, canopen::TimePoint now);
  void expand_move(std::uint8_t n);
  void start_task(canopen::TimePoint now);
  void start_lss(Task& t, canopen::TimePoint now);
  void start_sdo_write(const Task& t, canopen::TimePoint now);
  void end_job(const Task& t, canopen::TimePoint now);
  bool drive_current(canopen::TimePoint now);
  void push_front(std::vector<Task> ts);
  void fail_group(int group);
  // `report`: a problem event too (not when a retry event says it).
  void fail_current(const std::string& why, bool report = true);
  void mark_reset(canopen::TimePoint now);
  bool send_now(const can::Frame& f);
  void wait_boot(const Ctx& c, canopen::TimePoint now);
  void finish_wait_boots(canopen::TimePoint now);
  void start_sdo_fallback(const Ctx& c);
  void on_sdo_done(canopen::TimePoint now, std::error_code err);
  [[nodiscard]] std::string device_of(const Task& t) const;
  // Retries: a failure scheduled again; due ones searched again.
  // False when the device has nowhere to go (nothing to try again).
  bool retry_later(const Ctx& c, const std::string& cause, canopen::TimePoint now);
  void start_due_retries(canopen::TimePoint now);

  // clash_resolution.cpp: strategies (a), (b), (c)
  void expand_clash(std::uint8_t n);
  void switch_known(std::uint8_t n, const IdentityAnswers& v);
  void expand_fastscan_all(std::uint8_t n);
  void check_remaining(std::uint8_t n);
  void restore_known();

  // lss_outcomes.cpp: what each LSS result means
  void on_lss_result(const canopen::LssMaster::Result& r, canopen::TimePoint now);
  void carry_identity(int group, const LssAddress& a);
  void on_switch_selective(Task& t, const canopen::LssMaster::Result& r, canopen::TimePoint now);
  void on_slowscan_loop(const Task& t, const canopen::LssMaster::Result& r);
  void on_configure_id(const Task& t, const canopen::LssMaster::Result& r, canopen::TimePoint now);
  void on_identify_non_configured(const canopen::LssMaster::Result& r, canopen::TimePoint now);
  void on_fastscan(const Task& t, const canopen::LssMaster::Result& r, canopen::TimePoint now);
  // What the next Fastscan knows (FastscanSearch::plan with this run's finds).
  [[nodiscard]] canopen::FastscanPlan fastscan_plan(bool general) const;
  std::vector<Task> place_found(const LssAddress& a, const Task& t, bool& stranger);
  Ctx found_ctx(const LssAddress& a, std::uint8_t scan_node);
  std::vector<Task> recover_non_configured(const LssAddress& a, std::uint8_t from);
  [[nodiscard]] Ctx move_ctx(const LssAddress& a, std::uint8_t from, const Decision& d);

  can::FrameSink& sink_;
  const BusSettings& s_;
  Decisions& decisions_;
  IdentityProbe& probe_;
  Report& report_;
  canopen::LssMaster lss_;
  FastscanSearch search_;
  CommissionRetries retries_;
  std::optional<canopen::SdoClient> sdo_;  // the SDO node-ID fallback's download in flight
  std::deque<can::Frame> outbox_;

  bool permit_ = false;  // manual policy: request() until the work drains
  std::vector<Job> jobs_;
  std::optional<JobRun> run_;
  std::deque<Task> tasks_;
  std::optional<Task> current_;
  canopen::TimePoint current_started_{};
  canopen::TimePoint task_deadline_ = canopen::kNever;
  bool retry_start_ = false;
  int next_group_ = 1;
  std::array<NodeWork, 128> work_{};
  std::vector<BootWait> boot_waits_;
  // Boot-ups we caused (a reset, or a V3 slave leaving configuration with a
  // new node-ID) may come twice from one node-ID; they are no clash.
  canopen::TimePoint expected_bootups_until_ = canopen::TimePoint::min();
  // The latest reset we caused (NMT reset, or switch global waiting, which
  // makes a V3 slave with a new node-ID reset itself): boot-up times count
  // from here.
  canopen::TimePoint last_reset_{};
};

}  // namespace cobridge::bus::discovery
