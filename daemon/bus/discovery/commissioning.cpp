// Commissioning orchestration, part 1: the job queue, the move job and the
// task interpreter (see commissioning.hpp). Clash strategies are in
// clash_resolution.cpp, the meaning of LSS results in lss_outcomes.cpp.
#include "bus/discovery/commissioning.hpp"

#include "base/number_text.hpp"
#include "canopen/cob_id.hpp"
#include "canopen/nmt.hpp"
#include "bus/discovery/lss_families.hpp"

#include <algorithm>
#include <array>
#include <span>

namespace cobridge::bus::discovery {

using canopen::kNever;
using canopen::LssErrc;
using canopen::LssMode;
using canopen::TimePoint;

Commissioning::Commissioning(can::FrameSink& sink, const BusSettings& settings, Decisions& decisions,
                             IdentityProbe& probe, Report& report, canopen::LssMasterConfig lss_config)
    : sink_(sink),
      s_(settings),
      decisions_(decisions),
      probe_(probe),
      report_(report),
      lss_(sink, lss_config),
      search_(report) {}

// ---- the job queue -----------------------------------------------------------

void Commissioning::queue(Job j) {
  if (s_.bus.commissioning == config::Commissioning::off) return;
  if (std::find(jobs_.begin(), jobs_.end(), j) == jobs_.end()) jobs_.push_back(j);
}

void Commissioning::request() {
  if (s_.bus.commissioning == config::Commissioning::off) return;
  permit_ = true;
  queue(Job{Job::Kind::non_configured, 0});
}

bool Commissioning::may_commission() const noexcept {
  switch (s_.bus.commissioning) {
    case config::Commissioning::automatic: return true;
    case config::Commissioning::manual: return permit_;
    case config::Commissioning::off: return false;
  }
  return false;
}

bool Commissioning::pending() const noexcept {
  return !jobs_.empty() && !may_commission() && s_.bus.commissioning != config::Commissioning::off &&
         std::any_of(jobs_.begin(), jobs_.end(), [](const Job& j) { return j.kind != Job::Kind::non_configured; });
}

bool Commissioning::resetting() const noexcept {
  // Looking for non-configured devices (Fastscan, node-ID for what it finds)
  // touches only slaves at FFh: configured devices may be configured meanwhile,
  // so a stranger's scan never holds them up.
  const bool only_non_configured = run_ && run_->job.kind == Job::Kind::non_configured;
  return !idle() && !only_non_configured;
}

void Commissioning::expand(const Job& j, TimePoint now) {
  run_ = JobRun{};
  run_->job = j;
  run_->started = now;
  switch (j.kind) {
    case Job::Kind::move: expand_move(j.node); break;
    case Job::Kind::clash: expand_clash(j.node); break;
    case Job::Kind::non_configured: tasks_.push_back(make(Op::identify_non_configured)); break;
  }
  Task end = make(Op::job_end);
  end.node = j.node;
  tasks_.push_back(end);
  if (j.node != 0) work_[j.node].busy = true;
}

Ctx Commissioning::move_ctx(const LssAddress& a, std::uint8_t from, const Decision& d) {
  Ctx c;
  c.identity = a;
  c.from = from;
  c.target = d.target;
  c.device = d.device;
  c.replaces = d.replaces;
  c.replaced = d.replaced;
  c.group = next_group_++;
  return c;
}

void Commissioning::expand_move(std::uint8_t n) {
  const NodePicture& node = probe_.picture()[n];
  if (node.ids.size() != 1 || node.clash) return;
  const LssAddress a = node.ids[0];
  const Decision d = decisions_.decide(a);
  if (d.target == 0 || d.target == n || !decisions_.node_free_for(d.target, a)) return;
  Ctx c = move_ctx(a, n, d);
  c.sdo_fallback = sdo_node_id_object(a).has_value();
  run_->device = who(c);
  tasks_.push_back(make(Op::switch_selective, c));
  for (auto& t : assign_tasks(c)) tasks_.push_back(std::move(t));
  tasks_.push_back(nmt_task(canopen::NmtCommand::reset_comm, n, c.group));
  tasks_.push_back(make(Op::wait_boots));
}

// ---- the task interpreter -------------------------------------------------------

bool Commissioning::drive(TimePoint now, bool probing) {
  if (current_) return drive_current(now);
  if (tasks_.empty()) {
    start_due_retries(now);
    // A search for non-configured devices (LSS at FFh) may start while a
    // probe runs; jobs that move or reset configured devices wait for it.
    auto next = jobs_.begin();
    if (probing)
      next = std::find_if(jobs_.begin(), jobs_.end(), [](const Job& j) { return j.kind == Job::Kind::non_configured; });
    if (next == jobs_.end() || !may_commission()) {
      if (jobs_.empty() && s_.bus.commissioning == config::Commissioning::manual) permit_ = false;
      return false;
    }
    const Job j = *next;
    jobs_.erase(next);
    expand(j, now);
    return true;
  }
  current_ = std::move(tasks_.front());
  tasks_.pop_front();
  start_task(now);
  return true;
}

bool Commissioning::drive_current(TimePoint now) {
  switch (current_->op) {
    case Op::settle:
      if (now >= task_deadline_) current_.reset();
      return !current_;
    case Op::wait_boots: {
      const bool all = std::all_of(boot_waits_.begin(), boot_waits_.end(), [](const BootWait& w) { return w.seen; });
      if (all || now >= task_deadline_) finish_wait_boots(now);
      return !current_;
    }
    default: break;
  }
  if (retry_start_) {
    if (now < task_deadline_) return false;
    retry_start_ = false;
    start_task(now);
    return true;
  }
  if (current_->op != Op::sdo_write) return false;  // an LSS operation: its result comes through poll_lss
  task_deadline_ = sdo_->process(now);
  if (auto r = sdo_->take_result()) on_sdo_done(now, r->error);
  return !current_;
}

bool Commissioning::poll_lss(TimePoint now) {
  std::uint32_t n = 0;
  while (!outbox_.empty() && n < s_.opt.burst) {
    if (!sink_.send(outbox_.front())) break;
    outbox_.pop_front();
    ++n;
  }
  (void)lss_.process(now);
  auto r = lss_.take_result();
  if (!r) return false;
  on_lss_result(*r, now);
  return true;
}

TimePoint Commissioning::next_deadline(TimePoint now) {
  TimePoint next = lss_.process(now);
  if (!outbox_.empty()) next = std::min(next, now + std::chrono::milliseconds(1));
  if (current_) next = std::min(next, task_deadline_);
  return std::min(next, retries_.next_due());
}

void Commissioning::start_task(TimePoint now) {
  Task& t = *current_;
  current_started_ = now;
  task_deadline_ = kNever;
  switch (t.op) {
    case Op::nmt:
      if (t.cmd == canopen::NmtCommand::reset_comm || t.cmd == canopen::NmtCommand::reset_node) mark_reset(now);
      (void)send_now(canopen::make_nmt(t.cmd, t.node));
      current_.reset();
      return;
    case Op::settle:
      task_deadline_ = now + t.duration;
      return;
    case Op::restore_known: restore_known(); return;
    case Op::check_remaining: check_remaining(t.node); return;
    case Op::sdo_write: start_sdo_write(t, now); return;
    case Op::wait_boots:
      task_deadline_ = now + s_.opt.bootup_timeout;
      return;
    case Op::job_end: end_job(t, now); return;
    default: start_lss(t, now); return;
  }
}

void Commissioning::start_lss(Task& t, TimePoint now) {
  std::error_code ec;
  switch (t.op) {
    case Op::switch_selective: {
      const LssAddress a = t.ctx.candidates.empty() ? t.ctx.identity : t.ctx.candidates[t.attempts];
      ec = lss_.switch_state_selective(a, now);
      break;
    }
    case Op::slowscan_one:
    case Op::slowscan_loop: ec = lss_.slowscan(t.range, now); break;
    case Op::configure_id: ec = lss_.configure_node_id(t.ctx.target, now); break;
    case Op::store: ec = lss_.store_configuration(now); break;
    case Op::identify_non_configured: ec = lss_.identify_non_configured(now); break;
    case Op::fastscan_loop: ec = lss_.fastscan(now, fastscan_plan(true)); break;
    case Op::fastscan_known: ec = lss_.fastscan(now, fastscan_plan(false)); break;
    case Op::global:
      ec = lss_.switch_state_global(t.mode);
      if (!ec) {
        if (t.mode == LssMode::kWaiting) mark_reset(now);
        current_.reset();  // `t` is gone: no answer to wait for
      }
      break;
    default: break;
  }
  if (ec == make_error_code(LssErrc::kBusy) || ec == make_error_code(LssErrc::kSendFailed)) {
    task_deadline_ = now + std::chrono::milliseconds(1);  // retry the start
    retry_start_ = true;
  } else if (ec) {
    fail_current(ec.message());
  }
}

void Commissioning::end_job(const Task& t, TimePoint now) {
  if (t.node != 0) {
    work_[t.node].busy = false;
    // The device(s) left this node-ID: see what is there now.
    probe_.want(t.node);
  }
  if (run_) {
    const Job j = run_->job;
    if (j.kind != Job::Kind::non_configured || !run_->found.empty())
      report_.timing(j.kind == Job::Kind::clash  ? "clash-resolution"
                     : j.kind == Job::Kind::move ? "commission"
                                                 : "commission-non-configured",
                     run_->device, now - run_->started);
    if (j.kind == Job::Kind::clash) {
      // Resolved only when the probe of the node (requested above) finds at
      // most one device left there (clash_settled).
      NodeWork& w = work_[j.node];
      w.clash_verify = true;
      w.clash_moved_any = w.clash_moved_any || run_->moved_any;
      ++w.clash_strategy;
    }
  }
  run_.reset();
  current_.reset();
}

void Commissioning::push_front(std::vector<Task> ts) {
  for (auto it = ts.rbegin(); it != ts.rend(); ++it) tasks_.push_front(std::move(*it));
}

void Commissioning::fail_group(int group) {
  if (group == 0) return;
  std::erase_if(tasks_, [group](const Task& t) { return t.ctx.group == group; });
  tasks_.push_front(global_task(LssMode::kWaiting));
}

void Commissioning::fail_current(const std::string& why, bool report) {
  const Task t = *current_;
  current_.reset();
  if (report) report_.problem(who(t.ctx) + ": " + why, t.ctx.from, t.ctx.identity);
  fail_group(t.ctx.group);
}

void Commissioning::mark_reset(TimePoint now) {
  expected_bootups_until_ = now + s_.opt.bootup_clash_window;
  last_reset_ = now;
}

bool Commissioning::send_now(const can::Frame& f) {
  if (outbox_.empty() && sink_.send(f)) return true;
  outbox_.push_back(f);
  return false;
}

std::string Commissioning::device_of(const Task& t) const {
  if (t.ctx.device.empty() && t.ctx.identity.serial == 0) return run_ ? run_->device : "";
  return who(t.ctx);
}

// ---- retries ------------------------------------------------------------

// Never dropped: the device is tried again once its wait is over, whatever
// failed; the event tells the bus manager (status, log) each time.
bool Commissioning::retry_later(const Ctx& c, const std::string& cause, TimePoint now) {
  if (!canopen::cob::valid_node_id(c.target)) return false;  // nowhere to go: nothing to try again
  if (run_) run_->failed.insert(c.identity.serial);
  const RetryEntry& e = retries_.failed(c.identity, c.device, c.from, cause, now);
  const auto wait = CommissionRetries::wait_after(e.failures);
  DiscoveryEvent ev;
  ev.kind = DiscoveryEventKind::retry;
  ev.node_id = c.from;
  ev.target_node_id = c.target;
  ev.identity = c.identity;
  ev.device = c.device;
  ev.count = e.failures;
  ev.retry_in = wait;
  ev.text = who(c) + ": commissioning failed (try " + std::to_string(e.failures) + "): " + cause + "; next try in " +
            std::to_string(std::chrono::duration_cast<std::chrono::seconds>(wait).count()) + " s";
  report_.event(std::move(ev));
  return true;
}

void Commissioning::at_target(const LssAddress& a) { retries_.succeeded(a); }

// A device still at its old node-ID is probed again (its move job follows
// from the probe); one at FFh is searched by the non-configured job.
void Commissioning::start_due_retries(TimePoint now) {
  const std::vector<RetryEntry> due = retries_.take_due(now);
  if (due.empty()) return;
  for (const auto& e : due)
    if (canopen::cob::valid_node_id(e.node)) probe_.want(e.node);
  queue(Job{Job::Kind::non_configured, 0});
}

// ---- boot-ups ----------------------------------------------------------------------

void Commissioning::wait_boot(const Ctx& c, TimePoint now) {
  BootWait w;
  w.ctx = c;
  w.registered = now;
  boot_waits_.push_back(std::move(w));
}

void Commissioning::on_bootups(const std::bitset<128>& booted, TimePoint now) {
  for (std::uint8_t n = 1; n <= 127; ++n) {
    if (!booted[n]) continue;
    for (auto& w : boot_waits_) {
      if (w.seen || w.ctx.target != n) continue;
      w.seen = true;
      retries_.succeeded(w.ctx.identity);
      report_.timing("boot-up", who(w.ctx), now - std::max(last_reset_, w.registered));
      DiscoveryEvent e;
      e.kind = DiscoveryEventKind::commissioned;
      e.node_id = n;
      e.previous_node_id = w.ctx.from;
      e.identity = w.ctx.identity;
      e.device = w.ctx.device;
      e.replaces = w.ctx.replaces;
      e.replaced = w.ctx.replaced;
      e.text = who(w.ctx) + " moved from " +
               (w.ctx.from == canopen::cob::kNodeIdUnconfigured ? std::string("non-configured")
                                                               : "node " + std::to_string(w.ctx.from)) +
               " to node " + std::to_string(n);
      report_.event(std::move(e));
      if (run_) run_->moved_any = true;
    }
  }
}

void Commissioning::finish_wait_boots(TimePoint now) {
  current_.reset();
  for (const auto& w : boot_waits_)
    if (!w.seen) {
      const std::string why = "no boot-up at node " + std::to_string(w.ctx.target) + " after the reset";
      // A probe of its target finding it there ends the tries.
      if (!retry_later(w.ctx, why, now)) report_.problem(who(w.ctx) + ": " + why, w.ctx.target, w.ctx.identity);
    }
  boot_waits_.clear();
}

// ---- SDO node-ID fallback (J§1.3.3 0x2000, E§4.3 0x2000, F§7.4 0x3000) ----------------

void Commissioning::start_sdo_fallback(const Ctx& c) {
  const auto obj = sdo_node_id_object(c.identity);
  std::erase_if(tasks_, [g = c.group](const Task& x) { return x.ctx.group == g; });
  Task w = make(Op::sdo_write, c);
  w.node = c.from;
  w.index = obj->index;
  w.sub = 0;
  w.value = static_cast<std::uint32_t>(c.target - obj->minus);
  w.len = 1;
  Task s = make(Op::sdo_write, c);
  s.node = c.from;
  s.index = kStoreObject;
  s.sub = obj->save_sub;
  s.value = kSaveSignature;
  s.len = 4;
  push_front({w, s, nmt_task(canopen::NmtCommand::reset_node, c.from, c.group)});
}

void Commissioning::start_sdo_write(const Task& t, TimePoint now) {
  // Through the project's one SDO client; it re-sends an unanswered request
  // sdo_retries times.
  canopen::SdoClientConfig cfg;
  cfg.timeout = s_.sdo_timeout;
  cfg.retries = s_.bus.sdo_retries;
  cfg.buffer_size = 8;
  sdo_.emplace(sink_, t.node, cfg);
  const std::array<std::uint8_t, 4> b{static_cast<std::uint8_t>(t.value), static_cast<std::uint8_t>(t.value >> 8),
                                      static_cast<std::uint8_t>(t.value >> 16),
                                      static_cast<std::uint8_t>(t.value >> 24)};
  const std::error_code ec = sdo_->start_download(t.index, t.sub, std::span<const std::uint8_t>(b.data(), t.len), now);
  if (ec == std::make_error_code(std::errc::no_buffer_space)) {
    task_deadline_ = now + std::chrono::milliseconds(1);  // the sink is full: retry the start
    retry_start_ = true;
  } else if (ec) {
    fail_current(ec.message());
  } else {
    task_deadline_ = now + s_.sdo_timeout;
  }
}

void Commissioning::on_sdo_done(TimePoint now, std::error_code err) {
  const Task t = *current_;
  sdo_.reset();
  report_.timing(t.index == kStoreObject ? "sdo-save" : "sdo-node-id", who(t.ctx), now - current_started_);
  if (err) {
    const bool timed_out = err == make_error_code(canopen::SdoAbort::kProtocolTimedOut);
    const std::string abort = "abort " + hex(static_cast<std::uint32_t>(err.value()), 8);
    const std::string why = "SDO write " + hex(t.index, 4).substr(2) + "/" + std::to_string(t.sub) + " failed (" +
                            (timed_out ? std::string("timeout") : abort) + ")";
    fail_current(why, !retry_later(t.ctx, why, now));
    return;
  }
  current_.reset();
  if (t.index != kStoreObject && t.ctx.boot_wait) wait_boot(t.ctx, now);
}

}  // namespace cobridge::bus::discovery
