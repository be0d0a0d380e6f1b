// Commissioning orchestration, part 2: taking a node-ID clash apart (CiA 305
// switch selective, Slowscan, Fastscan), strategies (a), (b) and (c) of
// commissioning.hpp, and whether the probe afterwards found it resolved.
#include "bus/discovery/commissioning.hpp"

#include "canopen/cob_id.hpp"
#include "config/known_models.hpp"

#include <algorithm>

namespace cobridge::bus::discovery {

using canopen::LssMode;

namespace {

// Clash strategies, one per resolution run at a node; the probe after each
// run tells whether the next is needed (NodeWork::clash_strategy):
//   0: (a) switch selective where the identity is known, (b) Slowscan for
//      the pre-Fastscan series (a) left, (c) Fastscan for the rest;
//   1: (b) Slowscan over every pre-Fastscan product seen, then (c) for
//      whatever it did not find;
//   2: (c) for everyone.
constexpr std::uint8_t kClashStrategies = 3;

// The vendor/product/revision combinations the probe of a clash saw that
// configured device `c` (serial `s`) can have: vendor and product from the
// config, else from its model; every revision seen (the answers of several
// devices cannot be paired up).
std::vector<LssAddress> candidates_for(const config::Device& c, std::uint32_t s, const IdentityAnswers& v) {
  std::vector<LssAddress> out;
  const config::KnownModel* m = c.model.empty() ? nullptr : config::find_model(c.model);
  std::optional<std::uint32_t> vendor = c.vendor;
  if (!vendor && m) vendor = m->vendor;
  if (!vendor || !v[0].contains(*vendor)) return out;
  for (std::uint8_t ip = 0; ip < v[1].n; ++ip) {
    const std::uint32_t p = v[1].v[ip];
    if (c.product && *c.product != p) continue;
    if (!c.product && m && !m->products.empty() &&
        std::find(m->products.begin(), m->products.end(), p) == m->products.end())
      continue;
    if (!c.product && !m) continue;  // nothing says which product it is
    for (std::uint8_t ir = 0; ir < v[2].n; ++ir) out.push_back(LssAddress{*vendor, p, v[2].v[ir], s});
  }
  return out;
}

}  // namespace

void Commissioning::expand_clash(std::uint8_t n) {
  NodeWork& w = work_[n];
  const std::uint8_t strategy = w.clash_strategy;
  run_->device = "node " + std::to_string(n);
  const IdentityAnswers v = probe_.picture()[n].seen;
  for (std::uint8_t i = 0; i < v[3].n; ++i) run_->serials.insert(v[3].v[i]);
  w.clash_count = static_cast<std::uint32_t>(std::max<std::size_t>(run_->serials.size(), 2));
  w.clash_moved_any = false;
  if (strategy == 0) switch_known(n, v);
  // (b) Slowscan for the pre-Fastscan series in the clash, if (a) left any.
  const bool slowscan =
      strategy == 1 || (strategy == 0 && (run_->handled.size() < run_->serials.size() || run_->serials.empty()));
  if (slowscan)
    for (auto& t : FastscanSearch::slowscan_of(v, n, false)) tasks_.push_back(std::move(t));
  // (c) whatever is left.
  Task check = make(Op::check_remaining);
  check.node = n;
  tasks_.push_back(check);
  tasks_.push_back(nmt_task(canopen::NmtCommand::reset_comm, n));
  tasks_.push_back(make(Op::wait_boots));
}

// (a) switch selective where the identity is known.
void Commissioning::switch_known(std::uint8_t n, const IdentityAnswers& v) {
  const bool full = v[0].n == 1 && v[1].n == 1 && v[2].n == 1;
  for (std::uint32_t s : run_->serials) {
    LssAddress a;
    a.serial = s;
    std::vector<LssAddress> cands;
    if (full) {
      a.vendor = v[0].v[0];
      a.product = v[1].v[0];
      a.revision = v[2].v[0];
    } else {
      const config::Device* c = decisions_.configured_by_serial(s);
      if (!c) continue;
      cands = candidates_for(*c, s, v);
      if (cands.empty()) continue;
      a = cands.front();
    }
    const Decision d = decisions_.decide(a);
    run_->handled.insert(s);
    if (!d.problem.empty()) report_.problem(d.problem, n, a);
    if (d.target == 0 || d.target == n) continue;  // stays where it is
    if (!decisions_.node_free_for(d.target, a)) {
      report_.problem("node " + std::to_string(d.target) + " for " + d.device + " is held by another device", n, a);
      continue;
    }
    decisions_.remember(a, d.target);
    Ctx c = move_ctx(a, n, d);
    c.candidates = std::move(cands);
    tasks_.push_back(make(Op::switch_selective, c));
    for (auto& t : assign_tasks(c)) tasks_.push_back(std::move(t));
  }
}

// After (a)/(b): anything left at the clash node -> (c).
void Commissioning::check_remaining(std::uint8_t n) {
  std::set<std::uint32_t> left;
  for (std::uint32_t s : run_->serials)
    if (!run_->handled.contains(s)) left.insert(s);
  current_.reset();
  if (!left.empty() || work_[n].clash_strategy >= 2) expand_fastscan_all(n);
}

// (c): every device non-configured, then Fastscan. `n` is the clash node.
void Commissioning::expand_fastscan_all(std::uint8_t n) {
  const BusPicture& pic = probe_.picture();
  run_->known.clear();
  for (std::uint8_t x = 1; x <= 127; ++x) {
    if (x == n || pic[x].clash) continue;
    for (const auto& id : pic[x].ids) run_->known.emplace_back(id, decisions_.assigned_to(id).value_or(x));
  }
  for (const auto& [id, t] : decisions_.session().assigned)
    if (std::none_of(run_->known.begin(), run_->known.end(), [&](const auto& k) { return same_device(k.first, id); }))
      run_->known.emplace_back(id, t);
  std::vector<Task> v;
  v.push_back(global_task(LssMode::kConfiguration));
  Ctx ff;
  ff.target = canopen::cob::kNodeIdUnconfigured;
  ff.store = false;
  ff.boot_wait = false;
  v.push_back(make(Op::configure_id, ff));
  v.push_back(global_task(LssMode::kWaiting));
  v.push_back(nmt_task(canopen::NmtCommand::reset_comm, 0));
  Task settle = make(Op::settle);
  settle.duration = s_.lss_timeout;
  v.push_back(settle);
  Task fs = make(Op::fastscan_loop);
  fs.node = n;
  v.push_back(fs);
  // The pre-Fastscan series (J: DSP-305 V1.1.2) is non-configured now too
  // and Fastscan cannot find it: Slowscan does.
  for (auto& t : FastscanSearch::slowscan_of(pic[n].seen, n, true)) v.push_back(std::move(t));
  v.push_back(make(Op::restore_known));
  v.push_back(nmt_task(canopen::NmtCommand::reset_comm, 0));
  push_front(std::move(v));
}

// After (c): the devices known before that no scan found get their node-IDs back.
void Commissioning::restore_known() {
  std::vector<Task> v;
  for (const auto& [id, node] : run_->known) {
    if (std::any_of(run_->found.begin(), run_->found.end(), [&](const LssAddress& f) { return same_device(f, id); }))
      continue;
    Ctx c;
    c.identity = id;
    c.from = canopen::cob::kNodeIdUnconfigured;
    c.target = node;
    c.store = false;
    c.boot_wait = false;
    c.group = next_group_++;
    v.push_back(make(Op::switch_selective, c));
    for (auto& x : assign_tasks(c)) v.push_back(std::move(x));
  }
  current_.reset();
  push_front(std::move(v));
}

void Commissioning::clash_settled(std::uint8_t n) {
  NodeWork& w = work_[n];
  w.clash_strategy = 0;
  if (!w.clash_verify) return;
  w.clash_verify = false;
  DiscoveryEvent e;
  e.kind = DiscoveryEventKind::clash_resolved;
  e.node_id = n;
  e.count = w.clash_count;
  e.text = "clash at node " + std::to_string(n) + " resolved" + (w.clash_moved_any ? "" : " (nothing could be moved)");
  report_.event(std::move(e));
}

void Commissioning::clash_persists(std::uint8_t n, std::uint32_t count) {
  // A resolution ran and several devices still answer here: not resolved;
  // the next strategy takes over, until none is left.
  work_[n].clash_verify = false;
  if (work_[n].clash_strategy >= kClashStrategies) {
    report_.problem("the clash at node " + std::to_string(n) + " could not be resolved (" + std::to_string(count) +
                        " devices still answer there)",
                    n);
    return;
  }
  queue(Job{Job::Kind::clash, n});
}

}  // namespace cobridge::bus::discovery
