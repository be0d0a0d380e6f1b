// Commissioning orchestration, part 3: what each LSS result means for the
// work that follows (retries, the SDO fallback, devices found by Fastscan or
// Slowscan and where they go). See commissioning.hpp.
#include "bus/discovery/commissioning.hpp"

#include "canopen/cob_id.hpp"

#include <algorithm>

namespace cobridge::bus::discovery {

using canopen::LssMode;
using canopen::LssRange;
using canopen::TimePoint;
using Result = canopen::LssMaster::Result;

namespace {
std::string slave_error_text(const Result& r) {
  return r.error ? r.error.message() : "slave error " + std::to_string(r.slave_error);
}
// The steps whose LSS result is timed as it comes (the searches time their own).
const char* timed_step(Op op) noexcept {
  switch (op) {
    case Op::switch_selective: return "switch-selective";
    case Op::slowscan_one:
    case Op::slowscan_loop: return "slowscan";
    case Op::configure_id: return "configure-node-id";
    case Op::store: return "store";
    default: return nullptr;
  }
}
// Identified by a probe at another node-ID than `except`.
bool present_elsewhere(const BusPicture& picture, const LssAddress& a, std::uint8_t except) {
  for (std::uint8_t x = 1; x <= 127; ++x)
    if (x != except)
      for (const auto& id : picture[x].ids)
        if (same_device(id, a)) return true;
  return false;
}
}  // namespace

void Commissioning::on_lss_result(const Result& r, TimePoint now) {
  if (!current_) return;
  Task t = *current_;
  current_.reset();
  if (const char* step = timed_step(t.op))
    report_.timing(step, t.op == Op::slowscan_loop && run_ ? run_->device : device_of(t), r);
  switch (t.op) {
    case Op::switch_selective: on_switch_selective(t, r, now); return;
    case Op::slowscan_one:
      if (r.error) {
        current_ = t;
        fail_current("Slowscan found no device with " + describe(t.ctx.identity));
        return;
      }
      carry_identity(t.ctx.group, r.address);
      return;
    case Op::slowscan_loop: on_slowscan_loop(t, r); return;
    case Op::configure_id: on_configure_id(t, r, now); return;
    case Op::store:
      if (r.error || r.slave_error != 0)
        report_.problem(who(t.ctx) + ": LSS store configuration failed (" + slave_error_text(r) + "); node " +
                            std::to_string(t.ctx.target) + " holds until the next power-off",
                        t.ctx.target, t.ctx.identity);
      return;
    case Op::identify_non_configured: on_identify_non_configured(r, now); return;
    case Op::fastscan_known:
    case Op::fastscan_loop: on_fastscan(t, r, now); return;
    default: return;
  }
}

// The following tasks of a device carry the identity (revision) found.
void Commissioning::carry_identity(int group, const LssAddress& a) {
  for (auto& x : tasks_)
    if (x.ctx.group == group) x.ctx.identity = a;
}

void Commissioning::on_switch_selective(Task& t, const Result& r, TimePoint now) {
  if (!r.error) {
    if (t.ctx.target == 0) return;
    if (!t.ctx.candidates.empty()) t.ctx.identity = t.ctx.candidates[t.attempts];
    carry_identity(t.ctx.group, t.ctx.identity);
    return;
  }
  if (t.attempts + 1u < t.ctx.candidates.size()) {
    ++t.attempts;
    current_ = t;
    start_task(now);
    return;
  }
  if (!t.ctx.candidates.empty()) {
    // (a) with the revision unknown: Slowscan over every revision for this serial.
    Task s = make(Op::slowscan_one, t.ctx);
    const LssAddress& a = t.ctx.identity;
    s.range = LssRange{a.vendor, a.product, 0, 0xFFFFFFFFu, a.serial, a.serial};
    tasks_.push_front(s);
    return;
  }
  if (t.ctx.sdo_fallback) {
    start_sdo_fallback(t.ctx);
    return;
  }
  const std::string why = "no answer to LSS switch selective (" + describe(t.ctx.identity) + ")";
  if (!retry_later(t.ctx, why, now)) report_.problem(who(t.ctx) + ": " + why, t.ctx.from, t.ctx.identity);
  std::erase_if(tasks_, [g = t.ctx.group](const Task& x) { return x.ctx.group == g; });
}

// A Slowscan of a clash found `r.address`: its node-ID, then the next
// Slowscan above it.
void Commissioning::on_slowscan_loop(const Task& t, const Result& r) {
  if (r.error) return;  // kNotFound: no more devices in the range
  const LssAddress a = r.address;
  std::vector<Task> v;
  const bool elsewhere = present_elsewhere(probe_.picture(), a, t.node);
  const bool done = run_ && run_->handled.contains(a.serial);
  if (t.non_configured) {
    // (c) took every node-ID away: a device restore_known puts back is
    // left to it; any other gets its node-ID here.
    const bool known = run_ && std::any_of(run_->known.begin(), run_->known.end(),
                                           [&](const auto& k) { return same_device(k.first, a); });
    if (!known && !elsewhere) v = recover_non_configured(a, t.node);
  } else if (!elsewhere && !done) {
    if (run_) run_->handled.insert(a.serial);
    const Decision d = decisions_.decide(a);
    if (!d.problem.empty()) report_.problem(d.problem, t.node, a);
    if (d.target != 0 && d.target != t.node && decisions_.node_free_for(d.target, a)) {
      decisions_.remember(a, d.target);
      v = assign_tasks(move_ctx(a, t.node, d));
    }
  }
  if (v.empty()) v.push_back(global_task(LssMode::kWaiting));
  if (a.serial < 0xFFFFFFFFu) {
    Task next = t;
    next.range.serial_lo = a.serial + 1;
    v.push_back(next);
  }
  push_front(std::move(v));
}

void Commissioning::on_configure_id(const Task& t, const Result& r, TimePoint now) {
  if (r.error || r.slave_error != 0) {
    if (t.ctx.target == canopen::cob::kNodeIdUnconfigured) return;  // (c): nobody had to answer
    const std::string why = "LSS configure node-ID " + std::to_string(t.ctx.target) + " failed: " + slave_error_text(r);
    const bool retried = retry_later(t.ctx, why, now);
    current_ = t;
    fail_current(why, !retried);
    return;
  }
  if (t.ctx.boot_wait && canopen::cob::valid_node_id(t.ctx.target)) wait_boot(t.ctx, now);
}

void Commissioning::on_identify_non_configured(const Result& r, TimePoint now) {
  if (!r.answered) return;
  report_.timing("identify-non-configured", "", r);
  std::vector<Task> v = search_.searches(now, s_, probe_.picture());
  v.push_back(make(Op::wait_boots));
  push_front(std::move(v));
}

canopen::FastscanPlan Commissioning::fastscan_plan(bool general) const {
  std::vector<LssAddress> known, found;
  if (run_) {
    for (const auto& k : run_->known) known.push_back(k.first);
    found = run_->found;
  }
  return FastscanSearch::plan(general, s_, probe_.picture(), known, found);
}

// Both Fastscans loop until nobody is found: the targeted one (fastscan_known)
// finds configured devices only, the general one (fastscan_loop) them first
// and then whatever else answers.
void Commissioning::on_fastscan(const Task& t, const Result& r, TimePoint now) {
  const config::Device* c = r.error ? nullptr : discovery::configured_by_serial(r.address.serial, s_.devices);
  const bool general = t.op == Op::fastscan_loop;
  report_.timing(general ? "fastscan" : "fastscan-known", c ? c->name : general && run_ ? run_->device : "", r);
  if (r.error) {
    // Nobody left that Fastscan can find. A non-configured device answered
    // identify non-configured but Fastscan found none: it is of the
    // pre-Fastscan series (J, DSP-305 V1.1.2), which Slowscan finds.
    if (general && t.node == 0 && run_ && run_->job.kind == Job::Kind::non_configured && run_->found.empty() &&
        !run_->slowscanned) {
      run_->slowscanned = true;
      push_front(FastscanSearch::slowscan_all_pre_fastscan());
    }
    return;
  }
  if (search_.is_stranger(r.address)) {
    // A device reported before (it keeps answering at FFh): the loop ends
    // here, and the general scan backs off (the targeted one still runs).
    if (general) search_.back_off(now, std::chrono::seconds(s_.bus.discovery_period_s));
    push_front({global_task(LssMode::kWaiting)});
    return;
  }
  if (run_ && run_->failed.contains(r.address.serial)) {
    // Failed in this run already: it would be found first again and again.
    // The loop ends here; its retry (CommissionRetries) comes back for it.
    push_front({global_task(LssMode::kWaiting)});
    return;
  }
  bool stranger = false;
  std::vector<Task> v = place_found(r.address, t, stranger);
  if (!stranger) v.push_back(t);  // the next Fastscan
  // The guided scan finds configured models first: a stranger comes last,
  // and it would be found again first; it is searched once.
  else if (general) search_.back_off(now, std::chrono::seconds(s_.bus.discovery_period_s));
  push_front(std::move(v));
}

// A device Fastscan found at FFh: its tasks (node-ID, store, boot-up wait),
// or, when nothing gives it a node-ID, a stranger left non-configured.
std::vector<Task> Commissioning::place_found(const LssAddress& a, const Task& t, bool& stranger) {
  if (run_) run_->found.push_back(a);
  const Ctx c = found_ctx(a, t.node);
  stranger = c.target == 0;
  if (!stranger) return assign_tasks(c);
  search_.note_stranger(a, "not in the configuration; left without node-ID");
  return {global_task(LssMode::kWaiting)};
}

// Where a device found at FFh goes: back where (c) took it from, its
// configured / remembered node-ID, or nowhere (target 0).
Ctx Commissioning::found_ctx(const LssAddress& a, std::uint8_t scan_node) {
  Ctx c;
  c.identity = a;
  c.from = canopen::cob::kNodeIdUnconfigured;
  c.group = next_group_++;
  std::optional<std::uint8_t> known;
  if (run_)
    for (const auto& [id, node] : run_->known)
      if (same_device(id, a)) known = node;
  if (known) {
    c.target = *known;
    const auto at = probe_.present_at(a);
    c.store = !at || *at != c.target;  // unchanged node-IDs need no store (flash wear)
    c.boot_wait = c.store;
    if (at) c.from = *at;
    return c;
  }
  const Placement p = decisions_.place(a, scan_node, true);
  const Decision& d = p.decision;
  c.device = d.device;
  c.replaces = d.replaces;
  c.replaced = d.replaced;
  c.target = p.target;
  if (p.via == Placement::Via::decision && scan_node != 0) c.from = scan_node;
  if (p.via == Placement::Via::back) {
    // (c) made it non-configured; an unknown device goes back where it was, unstored.
    c.store = false;
    c.boot_wait = false;
  }
  if (p.pool_exhausted) search_.note_stranger(a, "not in the configuration and no free node-ID left in node_pool");
  if (!d.problem.empty()) report_.problem(d.problem, 0, a);
  if (c.target != 0) decisions_.remember(a, c.target);
  return c;
}

// A device found by Slowscan while non-configured (pre-Fastscan series
// after (c), or left so by an earlier run): its target node-ID, else back
// to the node it came from (`from`, 0 = none), not stored.
std::vector<Task> Commissioning::recover_non_configured(const LssAddress& a, std::uint8_t from) {
  if (run_) {
    run_->handled.insert(a.serial);
    run_->found.push_back(a);
  }
  const Placement p = decisions_.place(a, from, false);
  const Decision& d = p.decision;
  Ctx c = move_ctx(a, canopen::cob::valid_node_id(from) ? from : canopen::cob::kNodeIdUnconfigured, d);
  if (!d.problem.empty()) report_.problem(d.problem, from, a);
  if (p.via == Placement::Via::none) {
    report_.problem("non-configured " + describe(a) + " left without node-ID", 0, a);
    return {};
  }
  c.target = p.target;
  if (p.via == Placement::Via::back) {
    c.store = false;
    c.boot_wait = false;
  }
  decisions_.remember(a, c.target);
  return assign_tasks(c);
}

}  // namespace cobridge::bus::discovery
