// Discovery: see discovery.hpp. The work is split in three parts that meet in
// process(): the probe (raw SDO uploads of 0x1018/1..4, one sub-index per
// round, to many nodes at once), the decisions (which node-ID each identified
// device must have), and a queue of commissioning tasks (LSS, NMT, SDO steps)
// that runs one task at a time because the LSS channel serves one operation
// at a time.
#include "gateway/discovery.hpp"

#include "canopen/cob_id.hpp"
#include "canopen/lss_master.hpp"
#include "canopen/nmt.hpp"
#include "canopen/sdo_client.hpp"
#include "config/known_models.hpp"
#include "gateway/discovery/identity_probe.hpp"
#include "gateway/discovery/lss_families.hpp"
#include "gateway/discovery/node_assignment.hpp"

#include <algorithm>
#include <bitset>
#include <cstdio>
#include <deque>
#include <optional>
#include <set>
#include <span>
#include <utility>

namespace cobridge::gateway {

using canopen::Duration;
using canopen::kNever;
using canopen::LssAddress;
using canopen::LssErrc;
using canopen::LssMode;
using canopen::LssRange;
using canopen::TimePoint;
using discovery::AnswerSet;
using discovery::describe;
using discovery::hex32;
using discovery::is_pre_fastscan;
using discovery::sdo_node_id_object;
using discovery::kStoreObject;
using discovery::same_device;
using Values = discovery::AnswerSet;

const char* to_string(DiscoveryEventKind k) noexcept {
  switch (k) {
    case DiscoveryEventKind::identified: return "identified";
    case DiscoveryEventKind::commissioned: return "commissioned";
    case DiscoveryEventKind::clash_detected: return "clash-detected";
    case DiscoveryEventKind::clash_resolved: return "clash-resolved";
    case DiscoveryEventKind::problem: return "problem";
  }
  return "?";
}

namespace {

double to_ms(Duration d) noexcept { return std::chrono::duration<double, std::milli>(d).count(); }

}  // namespace

struct Discovery::Impl final : discovery::ProbeListener {
  // ---- settings -----------------------------------------------------------
  can::FrameSink& sink;
  DiscoveryOptions opt;
  config::Bus bus;
  std::vector<config::Device> devices;  // of this bus
  std::vector<Assignment> previous;
  Duration sdo_timeout{};
  Duration lss_timeout{};
  canopen::LssMaster lss;

  bool started = false;
  bool permit = false;  // manual policy: request_commission() until the work drains
  std::deque<can::Frame> outbox;

  // ---- per node-ID --------------------------------------------------------
  // Commissioning's bookkeeping per node-ID (what is there: probe.picture()).
  struct Node {
    // The next clash strategy to try here (see expand_clash); reset once
    // the node holds one device or none.
    std::uint8_t clash_strategy = 0;
    // A resolution ran: the next finished probe of this node decides whether
    // it worked (clash_resolved) or the next strategy must run.
    bool clash_verify = false;
    std::uint32_t clash_count = 0;    // devices seen when the resolution started
    bool clash_moved_any = false;
    bool busy = false;                // a commissioning job is about this node
  };
  std::array<Node, 128> nodes{};
  discovery::IdentityProbe probe;

  // ---- probe --------------------------------------------------------------
  TimePoint next_periodic = kNever;
  bool initial_probe_done = false;
  // Devices nobody configured, left at FFh; the general Fastscan's back-off.
  std::vector<LssAddress> strangers;
  TimePoint general_scan_not_before{};
  Duration general_scan_backoff{};

  // ---- commissioning ------------------------------------------------------
  struct Ctx {
    LssAddress identity;
    std::uint8_t from = 0;
    std::uint8_t target = 0;
    std::string device;
    std::string replaces;
    LssAddress replaced;
    bool store = true;
    bool boot_wait = true;
    bool sdo_fallback = false;
    // Switch selective: identities to try in turn (when the probe could not
    // pair the answers up: vendor/product from the config or its model,
    // every revision the probe saw).
    std::vector<LssAddress> candidates;
    int group = 0;
  };
  enum class Op : std::uint8_t {
    switch_selective,
    slowscan_one,     // (a) with the revision unknown: exact serial, any revision
    slowscan_loop,    // (b) every device of one vendor/product in the clash
    configure_id,
    store,
    global,
    nmt,
    settle,
    identify_non_configured,
    fastscan_loop,
    fastscan_known,   // a configured device's identity confirmed at FFh (CiA 305 Fastscan, BitChecked 0)
    restore_known,
    check_remaining,  // after (a)/(b): anything left at the clash node -> (c)
    sdo_write,
    wait_boots,
    job_end,
  };
  struct Task {
    Op op = Op::settle;
    Ctx ctx;
    LssRange range;
    LssMode mode = LssMode::kWaiting;
    canopen::NmtCommand cmd = canopen::NmtCommand::reset_comm;
    std::uint8_t node = 0;
    std::uint16_t index = 0;
    std::uint8_t sub = 0;
    std::uint32_t value = 0;
    std::uint8_t len = 0;
    Duration duration{};
    std::uint8_t attempts = 0;
    bool non_configured = false;  // slowscan_loop in (c): what it finds has no node-ID now
  };
  std::deque<Task> tasks;
  std::optional<Task> current;
  TimePoint current_started{};
  TimePoint task_deadline = kNever;
  int next_group = 1;

  struct Job {
    enum class Kind : std::uint8_t { move, clash, non_configured } kind;
    std::uint8_t node = 0;
    friend bool operator==(const Job&, const Job&) = default;
  };
  std::vector<Job> jobs;
  struct JobRun {
    Job job{};
    TimePoint started{};
    std::string device;
    // clash bookkeeping
    std::set<std::uint32_t> serials;    // seen at the clash node
    std::set<std::uint32_t> handled;    // moved or deliberately left
    std::vector<LssAddress> found;      // found by Fastscan in (c)
    std::vector<std::pair<LssAddress, std::uint8_t>> known;  // (c): identity -> node to restore
    bool moved_any = false;
    bool slowscanned = false;  // non-configured job: the Slowscan fallback ran
  };
  std::optional<JobRun> run;

  // The SDO node-ID fallback's download in flight.
  std::optional<canopen::SdoClient> sdo;

  struct BootWait {
    Ctx ctx;
    TimePoint registered{};
    bool seen = false;
  };
  std::vector<BootWait> boot_waits;

  discovery::Session session;  // decisions of this session (promises, swaps)
  // The last `identified` event per node: a new one goes out when the
  // identity or the decision (device, target) changes, or after a boot-up.
  struct Reported {
    std::uint8_t node = 0;
    LssAddress id;
    std::string device;
    std::uint8_t target = 0;
  };
  std::vector<Reported> reported_ids;
  // Unknown devices (and decisions that wait for a probe), decided again
  // when the presence picture changes.
  struct Unplaced {
    std::uint8_t node = 0;
    LssAddress id;
    bool bootup = false;   // the identification followed a boot-up
    bool pending = false;  // nothing reported yet: the decision waits
  };
  std::vector<Unplaced> unplaced;
  bool presence_changed = false;
  std::set<std::string> reported_problems;
  std::vector<DiscoveryEvent> events;
  std::vector<StepTiming> timings;

  Impl(can::FrameSink& s, const config::Config& config, std::size_t bus_index, std::vector<Assignment> prev,
       DiscoveryOptions o)
      : sink(s), opt(o), lss(s, lss_config_of(config.buses.at(bus_index), o)), probe(s, o) {
    apply_config(config, bus_index, std::move(prev));
  }

  // Waits learnt from the bus between lss_timeout_min_ms and lss_timeout_ms
  // (canopen::AnswerTiming); a test's fixed override keeps them fixed.
  static canopen::LssMasterConfig lss_config_of(const config::Bus& b, const DiscoveryOptions& o) {
    canopen::LssMasterConfig c;
    c.timeout = lss_timeout_of(b, o);
    c.min_timeout = o.lss_timeout != Duration{} ? c.timeout : Duration{std::chrono::milliseconds(b.lss_timeout_min_ms)};
    return c;
  }
  static Duration lss_timeout_of(const config::Bus& b, const DiscoveryOptions& o) {
    return o.lss_timeout != Duration{} ? o.lss_timeout : Duration{std::chrono::milliseconds(b.lss_timeout_ms)};
  }

  // A reload keeps the LSS master (and its timeout): it may be mid-operation.

  void apply_config(const config::Config& config, std::size_t bus_index, std::vector<Assignment> prev) {
    bus = config.buses.at(bus_index);
    devices.clear();
    for (const auto& d : config.devices)
      if (d.bus_index == bus_index) devices.push_back(d);
    previous = std::move(prev);
    sdo_timeout = opt.sdo_timeout != Duration{} ? opt.sdo_timeout : std::chrono::milliseconds(bus.sdo_timeout_ms);
    lss_timeout = lss_timeout_of(bus, opt);
    probe.set_sdo_timeout(sdo_timeout);
    probe.set_enabled(bus.discovery);
  }

  // ---- small helpers -----------------------------------------------------
  void timing(std::string step, std::string device, Duration d) {
    StepTiming t;
    t.step = std::move(step);
    t.device = std::move(device);
    t.milliseconds = to_ms(d);
    timings.push_back(std::move(t));
  }
  // An LSS operation's step: also how many exchanges it took and how many of
  // them waited out a timeout (issue 11: how each device was found).
  void timing(std::string step, std::string device, const canopen::LssMaster::Result& r) {
    timing(std::move(step), std::move(device), r.elapsed);
    timings.back().exchanges = r.steps;
    timings.back().timeouts = r.silent_steps;
  }
  static std::string node_name(std::uint8_t n) { return "node " + std::to_string(n); }
  std::string who(const Ctx& c) const { return c.device.empty() ? "serial " + std::to_string(c.identity.serial) : c.device; }

  void problem(std::string text, std::uint8_t node = 0, const LssAddress& id = {}) {
    if (!reported_problems.insert(text).second) return;
    DiscoveryEvent e;
    e.kind = DiscoveryEventKind::problem;
    e.node_id = node;
    e.identity = id;
    e.text = std::move(text);
    events.push_back(std::move(e));
  }

  [[nodiscard]] bool may_commission() const noexcept {
    switch (bus.commissioning) {
      case config::Commissioning::automatic: return true;
      case config::Commissioning::manual: return permit;
      case config::Commissioning::off: return false;
    }
    return false;
  }

  void queue_job(Job j) {
    if (bus.commissioning == config::Commissioning::off) return;
    if (std::find(jobs.begin(), jobs.end(), j) == jobs.end()) jobs.push_back(j);
  }

  bool send_now(const can::Frame& f) {
    if (outbox.empty() && sink.send(f)) return true;
    outbox.push_back(f);
    return false;
  }
  void flush() {
    std::uint32_t n = 0;
    while (!outbox.empty() && n < opt.burst) {
      if (!sink.send(outbox.front())) break;
      outbox.pop_front();
      ++n;
    }
  }

  // Every device present as far as the probes know, except at `except_node`.
  [[nodiscard]] std::optional<std::uint8_t> present_at(const LssAddress& a) const { return probe.present_at(a); }
  [[nodiscard]] std::optional<std::uint8_t> assigned_to(const LssAddress& a) const {
    return discovery::assigned_to(a, session);
  }
  void remember(const LssAddress& a, std::uint8_t node) {
    for (auto& [id, n] : session.assigned)
      if (same_device(id, a)) {
        n = node;
        return;
      }
    session.assigned.emplace_back(a, node);
  }

  [[nodiscard]] bool node_free_for(std::uint8_t node, const LssAddress& a) const {
    return discovery::node_free_for(node, a, picture(), session);
  }

  using Decision = discovery::Decision;

  // What the probes know, for the node-ID assignment.
  [[nodiscard]] const discovery::BusPicture& picture() const { return probe.picture(); }
  [[nodiscard]] const discovery::NodePicture& at(std::uint8_t n) const { return probe.picture()[n]; }
  [[nodiscard]] const config::Device* configured_by_serial(std::uint32_t serial) const {
    return discovery::configured_by_serial(serial, devices);
  }

  void request_probe(std::uint8_t n) noexcept {
    if (started) probe.request(n);
  }
  // `old` gives its place up: its node-ID is no longer promised to it.
  void forget(const LssAddress& old) {
    std::erase_if(session.assigned, [&](const auto& p) {
      return p.first.serial == old.serial && (old.vendor == 0 || p.first.vendor == old.vendor);
    });
  }

  // ---- decisions ----------------------------------------------------------
  // The pure assignment, and what it asks to be recorded.
  Decision decide(const LssAddress& a) {
    Decision d = discovery::decide(a, input(picture()));
    apply(d.effects);
    return d;
  }
  [[nodiscard]] discovery::AssignmentInput input(const discovery::BusPicture& pic) const {
    return discovery::AssignmentInput{bus, devices, previous, pic, session, initial_probe_done, probe.active()};
  }
  void apply(const discovery::Effects& e) {
    if (e.forget) forget(*e.forget);
    if (!e.unswap.empty()) std::erase_if(session.swapped, [&](const discovery::Swap& x) { return x.name == e.unswap; });
    if (e.swap) session.swapped.push_back(*e.swap);
    for (std::uint8_t n : e.probes) request_probe(n);
    if (e.recheck) presence_changed = true;
  }

  // ---- frames in ---------------------------------------------------------
  bool on_frame(const can::Frame& f, TimePoint now) noexcept {
    if (f.is_extended() || f.is_rtr() || f.is_error()) return false;
    if (f.id == canopen::cob::kLssSlaveToMaster) return lss.on_frame(f, now);
    if (f.id > canopen::cob::kSdoTxBase && f.id <= canopen::cob::kSdoTxBase + 127 && f.len == 8) {
      bool used = probe.on_sdo_answer(f, now);
      if (sdo && sdo->on_frame(f, now)) used = true;
      return used;
    }
    if (f.id > canopen::cob::kNmtErrorControlBase && f.id <= canopen::cob::kNmtErrorControlBase + 127 && f.len == 1) {
      probe.on_error_control(f, now, !current && tasks.empty() && now >= expected_bootups_until);
      return true;
    }
    return false;
  }

  // ---- probe results -------------------------------------------------------
  void on_probed(const discovery::ProbeResult& r) override {
    using Kind = discovery::ProbeResult::Kind;
    const std::uint8_t n = r.node;
    if (r.changed) presence_changed = true;
    switch (r.kind) {
      case Kind::nobody:
        clash_settled(n);
        if (r.was_known) std::erase_if(reported_ids, [n](const Reported& x) { return x.node == n; });
        std::erase_if(unplaced, [n](const Unplaced& u) { return u.node == n; });
        return;
      case Kind::refused:
        problem("node " + std::to_string(n) + " answers SDO but refuses to read its identity 0x1018", n);
        return;
      case Kind::incomplete: return;
      case Kind::identified: {
        const LssAddress a = at(n).ids[0];
        std::erase_if(unplaced, [&](const Unplaced& u) { return u.node == n && !same_device(u.id, a); });
        clash_settled(n);
        // The start-up probe decides once every node has answered (swaps need
        // to know which configured devices are missing).
        if (r.full && !initial_probe_done) return;
        on_identified(n, a, r.bootup);
        return;
      }
      case Kind::clash: on_clash(r); return;
    }
  }

  void on_clash(const discovery::ProbeResult& r) {
    const std::uint8_t n = r.node;
    const auto& seen = at(n).seen;
    std::erase_if(unplaced, [n](const Unplaced& u) { return u.node == n; });
    std::erase_if(reported_ids, [n](const Reported& x) { return x.node == n; });
    if (r.first_report) {
      DiscoveryEvent e;
      e.kind = DiscoveryEventKind::clash_detected;
      e.node_id = n;
      e.count = r.count;
      e.text = std::to_string(r.count) + " devices answer at node " + std::to_string(n);
      if (seen[3].n > 1) {
        e.text += " (serials";
        for (std::uint8_t i = 0; i < seen[3].n; ++i) e.text += " " + std::to_string(seen[3].v[i]);
        e.text += ")";
      }
      events.push_back(std::move(e));
    }
    // A resolution ran and several devices still answer here: not resolved;
    // the next strategy takes over, until none is left.
    nodes[n].clash_verify = false;
    if (nodes[n].clash_strategy >= kClashStrategies) {
      problem("the clash at node " + std::to_string(n) + " could not be resolved (" + std::to_string(r.count) +
                  " devices still answer there)",
              n);
      return;
    }
    queue_job(Job{Job::Kind::clash, n});
  }

  // The probe after a clash resolution found one device or none at `n`:
  // only now is the clash resolved.
  void clash_settled(std::uint8_t n) {
    Node& node = nodes[n];
    node.clash_strategy = 0;
    if (!node.clash_verify) return;
    node.clash_verify = false;
    DiscoveryEvent e;
    e.kind = DiscoveryEventKind::clash_resolved;
    e.node_id = n;
    e.count = node.clash_count;
    e.text = "clash at node " + std::to_string(n) + " resolved" + (node.clash_moved_any ? "" : " (nothing could be moved)");
    events.push_back(std::move(e));
  }

  void on_identified(std::uint8_t n, const LssAddress& a, bool bootup) {
    Decision d = decide(a);
    std::erase_if(unplaced, [n](const Unplaced& u) { return u.node == n; });
    if (d.wait) {
      // Reported once the probe it waits for has told whether the
      // configured device is still there.
      unplaced.push_back(Unplaced{n, a, bootup, true});
      return;
    }
    if (d.device.empty()) unplaced.push_back(Unplaced{n, a, false, false});
    if (d.target != 0) remember(a, d.target);
    auto it = std::find_if(reported_ids.begin(), reported_ids.end(), [n](const Reported& r) { return r.node == n; });
    const bool changed = it == reported_ids.end() || it->id != a || it->device != d.device || it->target != d.target;
    if (changed || bootup) {
      if (it == reported_ids.end()) it = reported_ids.insert(reported_ids.end(), Reported{});
      *it = Reported{n, a, d.device, d.target};
      DiscoveryEvent e;
      e.kind = DiscoveryEventKind::identified;
      e.node_id = n;
      e.target_node_id = d.target;
      e.at_target = d.target == n;
      e.boot_up = bootup;
      e.identity = a;
      e.device = d.device;
      e.replaces = d.replaces;
      e.replaced = d.replaced;
      e.text = "node " + std::to_string(n) + ": " + describe(a) + (d.device.empty() ? "" : " (" + d.device + ")") +
               (d.replaces.empty() ? ""
                                   : ", replaces the missing device " + d.replaces + " (serial " +
                                         std::to_string(d.replaced.serial) + ")") +
               (d.target == 0 ? "" : ", target node " + std::to_string(d.target));
      events.push_back(std::move(e));
    }
    if (!d.problem.empty()) problem(d.problem, n, a);
    if (d.target != 0 && d.target != n) {
      if (!node_free_for(d.target, a)) {
        problem("node " + std::to_string(d.target) + " for " + d.device + " is held by another device; " +
                    d.device + " stays at node " + std::to_string(n),
                n, a);
        return;
      }
      queue_job(Job{Job::Kind::move, n});
    }
  }

  // The presence picture changed: decide the unknown devices (and those
  // waiting for a probe) again. Between probe rounds only, so that no
  // decision rests on half a round.
  void reevaluate() {
    presence_changed = false;
    std::vector<Unplaced> list = std::exchange(unplaced, {});
    for (const Unplaced& u : list) {
      const discovery::NodePicture& node = at(u.node);
      // Gone or changed: the probe that saw it has reported it already.
      if (node.clash || node.ids.size() != 1 || !same_device(node.ids[0], u.id)) continue;
      on_identified(u.node, u.id, u.pending && u.bootup);
    }
  }

  void on_round_end(bool full, Duration took) override {
    timing(full ? "probe" : "probe-nodes", "", took);
    if (!full) return;
    if (!initial_probe_done) {
      initial_probe_done = true;
      // Decided only now that every configured device had its chance to
      // answer, so that a swap never takes the place of a present device.
      for (std::uint8_t n = 1; n <= 127; ++n)
        if (at(n).ids.size() == 1 && !at(n).clash) on_identified(n, at(n).ids[0], false);
    }
    queue_job(Job{Job::Kind::non_configured, 0});
  }

  void start_full_probe(TimePoint now) { probe.begin(now, true, std::bitset<128>{}.set().reset(0)); }
  void start_periodic_probe(TimePoint now) {
    std::bitset<128> v;
    for (std::uint8_t n = 1; n <= 127; ++n)
      if (!at(n).supervised && !nodes[n].busy) v.set(n);
    probe.begin(now, true, v);
  }

  bool drive_probe(TimePoint now) {
    if (probe.active()) return probe.drive(now, *this);
    // Probes wait while commissioning runs: devices are being reset and
    // made non-configured, and half a picture would start wrong work.
    if (!probe.requested() || current || !tasks.empty()) return false;
    probe.begin(now, false);
    return true;
  }

  // ---- boot-ups ----------------------------------------------------------
  void handle_bootups(TimePoint now) {
    const std::bitset<128> booted = probe.take_bootups();
    for (std::uint8_t n = 1; n <= 127; ++n) {
      if (!booted[n]) continue;
      for (auto& w : boot_waits) {
        if (w.seen || w.ctx.target != n) continue;
        w.seen = true;
        timing("boot-up", who(w.ctx), now - std::max(last_reset, w.registered));
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
        events.push_back(std::move(e));
        if (run) run->moved_any = true;
      }
      if (started) probe.want(n, true);
    }
  }

  // ---- tasks -------------------------------------------------------------
  static Task make(Op op, Ctx ctx) {
    Task t;
    t.op = op;
    t.ctx = std::move(ctx);
    return t;
  }
  static Task make(Op op) { return make(op, Ctx{}); }
  static Task make_global(LssMode m, int group = 0) {
    Task t = make(Op::global);
    t.mode = m;
    t.ctx.group = group;
    return t;
  }
  static Task make_nmt(canopen::NmtCommand c, std::uint8_t node, int group = 0) {
    Task t = make(Op::nmt);
    t.cmd = c;
    t.node = node;
    t.ctx.group = group;
    return t;
  }
  void push_front(std::vector<Task> ts) {
    for (auto it = ts.rbegin(); it != ts.rend(); ++it) tasks.push_front(std::move(*it));
  }
  // The device-level sequence once a device is in LSS configuration state.
  static std::vector<Task> assign_tasks(const Ctx& c) {
    std::vector<Task> v;
    v.push_back(make(Op::configure_id, c));
    if (c.store) v.push_back(make(Op::store, c));
    v.push_back(make_global(LssMode::kWaiting, c.group));
    return v;
  }
  void fail_group(int group) {
    if (group == 0) return;
    std::erase_if(tasks, [group](const Task& t) { return t.ctx.group == group; });
    tasks.push_front(make_global(LssMode::kWaiting));
  }

  void expand(const Job& j, TimePoint now) {
    run = JobRun{};
    run->job = j;
    run->started = now;
    switch (j.kind) {
      case Job::Kind::move: expand_move(j.node); break;
      case Job::Kind::clash: expand_clash(j.node); break;
      case Job::Kind::non_configured: {
        tasks.push_back(make(Op::identify_non_configured));
        break;
      }
    }
    Task end = make(Op::job_end);
    end.node = j.node;
    tasks.push_back(end);
    if (j.node != 0) nodes[j.node].busy = true;
  }

  void expand_move(std::uint8_t n) {
    const discovery::NodePicture& node = at(n);
    if (node.ids.size() != 1 || node.clash) return;
    const LssAddress a = node.ids[0];
    Decision d = decide(a);
    if (d.target == 0 || d.target == n || !node_free_for(d.target, a)) return;
    Ctx c;
    c.identity = a;
    c.from = n;
    c.target = d.target;
    c.device = d.device;
    c.replaces = d.replaces;
    c.replaced = d.replaced;
    c.sdo_fallback = sdo_node_id_object(a).has_value();
    c.group = next_group++;
    run->device = who(c);
    tasks.push_back(make(Op::switch_selective, c));
    for (auto& t : assign_tasks(c)) tasks.push_back(std::move(t));
    tasks.push_back(make_nmt(canopen::NmtCommand::reset_comm, n, c.group));
    tasks.push_back(make(Op::wait_boots));
  }

  // The vendor/product/revision combinations the probe of a clash saw that
  // configured device `c` (serial `s`) can have: vendor and product from the
  // config, else from its model; every revision seen (the answers of
  // several devices cannot be paired up).
  [[nodiscard]] static std::vector<LssAddress> candidates_for(const config::Device& c, std::uint32_t s,
                                                              const std::array<Values, 4>& v) {
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

  // Clash strategies, one per resolution run at a node; the probe after each
  // run tells whether the next is needed (node.clash_strategy):
  //   0: (a) switch selective where the identity is known, (b) Slowscan for
  //      the pre-Fastscan series (a) left, (c) Fastscan for the rest;
  //   1: (b) Slowscan over every pre-Fastscan product seen, then (c) for
  //      whatever it did not find;
  //   2: (c) for everyone.
  static constexpr std::uint8_t kClashStrategies = 3;

  void expand_clash(std::uint8_t n) {
    Node& node = nodes[n];
    const std::uint8_t strategy = node.clash_strategy;
    run->device = node_name(n);
    const auto v = at(n).seen;
    for (std::uint8_t i = 0; i < v[3].n; ++i) run->serials.insert(v[3].v[i]);
    node.clash_count = static_cast<std::uint32_t>(std::max<std::size_t>(run->serials.size(), 2));
    node.clash_moved_any = false;
    const bool full = v[0].n == 1 && v[1].n == 1 && v[2].n == 1;
    // (a) switch selective where the identity is known.
    if (strategy == 0)
    for (std::uint32_t s : run->serials) {
      LssAddress a;
      a.serial = s;
      std::vector<LssAddress> cands;
      if (full) {
        a.vendor = v[0].v[0];
        a.product = v[1].v[0];
        a.revision = v[2].v[0];
      } else {
        const config::Device* c = configured_by_serial(s);
        if (!c) continue;
        cands = candidates_for(*c, s, v);
        if (cands.empty()) continue;
        a = cands.front();
      }
      Decision d = decide(a);
      run->handled.insert(s);
      if (!d.problem.empty()) problem(d.problem, n, a);
      if (d.target == 0 || d.target == n) continue;  // stays where it is
      if (!node_free_for(d.target, a)) {
        problem("node " + std::to_string(d.target) + " for " + d.device + " is held by another device", n, a);
        continue;
      }
      remember(a, d.target);
      Ctx c;
      c.identity = a;
      c.from = n;
      c.target = d.target;
      c.device = d.device;
      c.replaces = d.replaces;
      c.replaced = d.replaced;
      c.candidates = std::move(cands);
      c.group = next_group++;
      tasks.push_back(make(Op::switch_selective, c));
      for (auto& t : assign_tasks(c)) tasks.push_back(std::move(t));
    }
    // (b) Slowscan for the pre-Fastscan series in the clash, if (a) left any.
    const bool slowscan = strategy == 1 || (strategy == 0 && (run->handled.size() < run->serials.size() || run->serials.empty()));
    if (slowscan) {
      for (auto& t : slowscan_tasks(v, n, false)) tasks.push_back(std::move(t));
    }
    // (c) whatever is left.
    Task check = make(Op::check_remaining);
    check.node = n;
    tasks.push_back(check);
    tasks.push_back(make_nmt(canopen::NmtCommand::reset_comm, n));
    tasks.push_back(make(Op::wait_boots));
  }

  // Slowscan over every pre-Fastscan product (J§1.2.1), for non-configured
  // devices of unknown identity.
  static std::vector<Task> slowscan_all_pre_fastscan() {
    std::vector<Task> out;
    for (const std::uint32_t p : discovery::kPreFastscanProducts) {
      Task t = make(Op::slowscan_loop);
      t.node = 0;
      t.non_configured = true;
      t.range = LssRange{discovery::kVendorNovotechnik, p, 0, 0xFFFFFFFFu, 0, 0xFFFFFFFFu};
      out.push_back(t);
    }
    return out;
  }

  // One Slowscan per pre-Fastscan vendor/product among the answers `v`.
  // `non_configured`: (c) took the node-IDs away, what is found has none.
  static std::vector<Task> slowscan_tasks(const std::array<Values, 4>& v, std::uint8_t n, bool non_configured) {
    std::vector<Task> out;
    for (std::uint8_t iv = 0; iv < v[0].n; ++iv)
      for (std::uint8_t ip = 0; ip < v[1].n; ++ip) {
        if (!is_pre_fastscan(v[0].v[iv], v[1].v[ip])) continue;
        Task t = make(Op::slowscan_loop);
        t.node = n;
        t.non_configured = non_configured;
        t.range = LssRange{v[0].v[iv], v[1].v[ip], 0, 0xFFFFFFFFu, 0, 0xFFFFFFFFu};
        out.push_back(t);
      }
    return out;
  }

  // (c): every device non-configured, then Fastscan. `n` is the clash node.
  void expand_fastscan_all(std::uint8_t n) {
    run->known.clear();
    for (std::uint8_t x = 1; x <= 127; ++x) {
      if (x == n || at(x).clash) continue;
      for (const auto& id : at(x).ids) run->known.emplace_back(id, assigned_to(id).value_or(x));
    }
    for (const auto& [id, t] : session.assigned)
      if (std::none_of(run->known.begin(), run->known.end(), [&](const auto& k) { return same_device(k.first, id); }))
        run->known.emplace_back(id, t);
    std::vector<Task> v;
    v.push_back(make_global(LssMode::kConfiguration));
    Ctx ff;
    ff.target = canopen::cob::kNodeIdUnconfigured;
    ff.store = false;
    ff.boot_wait = false;
    v.push_back(make(Op::configure_id, ff));
    v.push_back(make_global(LssMode::kWaiting));
    v.push_back(make_nmt(canopen::NmtCommand::reset_comm, 0));
    Task settle = make(Op::settle);
    settle.duration = lss_timeout;
    v.push_back(settle);
    Task fs = make(Op::fastscan_loop);
    fs.node = n;
    v.push_back(fs);
    // The pre-Fastscan series (J: DSP-305 V1.1.2) is non-configured now too
    // and Fastscan cannot find it: Slowscan does.
    for (auto& t : slowscan_tasks(at(n).seen, n, true)) v.push_back(std::move(t));
    v.push_back(make(Op::restore_known));
    v.push_back(make_nmt(canopen::NmtCommand::reset_comm, 0));
    push_front(std::move(v));
  }

  void start_task(TimePoint now) {
    Task& t = *current;
    current_started = now;
    task_deadline = kNever;
    std::error_code ec;
    switch (t.op) {
      case Op::switch_selective: {
        const LssAddress a = t.ctx.candidates.empty() ? t.ctx.identity : t.ctx.candidates[t.attempts];
        ec = lss.switch_state_selective(a, now);
        break;
      }
      case Op::slowscan_one: ec = lss.slowscan(t.range, now); break;
      case Op::slowscan_loop: ec = lss.slowscan(t.range, now); break;
      case Op::configure_id: ec = lss.configure_node_id(t.ctx.target, now); break;
      case Op::store: ec = lss.store_configuration(now); break;
      case Op::identify_non_configured: ec = lss.identify_non_configured(now); break;
      case Op::fastscan_loop: ec = lss.fastscan(now); break;
      case Op::fastscan_known: ec = lss.fastscan(now, known_fields(t.ctx.identity)); break;
      case Op::global: {
        ec = lss.switch_state_global(t.mode);
        if (!ec) {
          if (t.mode == LssMode::kWaiting) mark_reset(now);
          current.reset();
        }
        break;
      }
      case Op::nmt: {
        if (t.cmd == canopen::NmtCommand::reset_comm || t.cmd == canopen::NmtCommand::reset_node) mark_reset(now);
        (void)send_now(canopen::make_nmt(t.cmd, t.node));
        current.reset();
        return;
      }
      case Op::settle: task_deadline = now + t.duration; return;
      case Op::restore_known: {
        std::vector<Task> v;
        for (const auto& [id, node] : run->known) {
          if (std::any_of(run->found.begin(), run->found.end(), [&](const LssAddress& f) { return same_device(f, id); }))
            continue;
          Ctx c;
          c.identity = id;
          c.from = canopen::cob::kNodeIdUnconfigured;
          c.target = node;
          c.store = false;
          c.boot_wait = false;
          c.group = next_group++;
          v.push_back(make(Op::switch_selective, c));
          for (auto& x : assign_tasks(c)) v.push_back(std::move(x));
        }
        current.reset();
        push_front(std::move(v));
        return;
      }
      case Op::check_remaining: {
        std::set<std::uint32_t> left;
        for (std::uint32_t s : run->serials)
          if (!run->handled.contains(s)) left.insert(s);
        const std::uint8_t n = t.node;
        current.reset();
        if (!left.empty() || nodes[n].clash_strategy >= 2) expand_fastscan_all(n);
        return;
      }
      case Op::sdo_write: {
        // Through the project's one SDO client; it re-sends an unanswered
        // request sdo_retries times.
        canopen::SdoClientConfig cfg;
        cfg.timeout = sdo_timeout;
        cfg.retries = bus.sdo_retries;
        cfg.buffer_size = 8;
        sdo.emplace(sink, t.node, cfg);
        const std::array<std::uint8_t, 4> b{static_cast<std::uint8_t>(t.value), static_cast<std::uint8_t>(t.value >> 8),
                                            static_cast<std::uint8_t>(t.value >> 16),
                                            static_cast<std::uint8_t>(t.value >> 24)};
        ec = sdo->start_download(t.index, t.sub, std::span<const std::uint8_t>(b.data(), t.len), now);
        if (ec == std::make_error_code(std::errc::no_buffer_space)) {
          task_deadline = now + std::chrono::milliseconds(1);  // the sink is full: retry the start
          retry_start = true;
        } else if (ec) {
          fail_current(ec.message(), now);
        } else {
          task_deadline = now + sdo_timeout;
        }
        return;
      }
      case Op::wait_boots: {
        task_deadline = now + opt.bootup_timeout;
        return;
      }
      case Op::job_end: {
        if (t.node != 0) {
          nodes[t.node].busy = false;
          // The device(s) left this node-ID: see what is there now.
          probe.want(t.node);
        }
        if (run) {
          const Job j = run->job;
          if (j.kind != Job::Kind::non_configured || !run->found.empty())
            timing(j.kind == Job::Kind::clash ? "clash-resolution"
                   : j.kind == Job::Kind::move ? "commission"
                                               : "commission-non-configured",
                   run->device, now - run->started);
          if (j.kind == Job::Kind::clash) {
            // Resolved only when the probe of the node (requested above)
            // finds at most one device left there (clash_settled).
            Node& node = nodes[j.node];
            node.clash_verify = true;
            node.clash_moved_any = node.clash_moved_any || run->moved_any;
            ++node.clash_strategy;
          }
        }
        run.reset();
        current.reset();
        return;
      }
    }
    if (ec == make_error_code(LssErrc::kBusy) || ec == make_error_code(LssErrc::kSendFailed)) {
      task_deadline = now + std::chrono::milliseconds(1);  // retry the start
      retry_start = true;
    } else if (ec) {
      fail_current(ec.message(), now);
    }
  }
  bool retry_start = false;

  // Boot-ups we caused (a reset, or a V3 slave leaving configuration with a
  // new node-ID) may come twice from one node-ID; they are no clash.
  TimePoint expected_bootups_until = TimePoint::min();

  // The latest reset we caused (NMT reset, or switch global waiting, which
  // makes a V3 slave with a new node-ID reset itself): boot-up times count
  // from here.
  TimePoint last_reset{};

  void mark_reset(TimePoint now) {
    expected_bootups_until = now + opt.bootup_clash_window;
    last_reset = now;
  }

  void fail_current(const std::string& why, TimePoint) {
    const Task t = *current;
    current.reset();
    problem(who(t.ctx) + ": " + why, t.ctx.from, t.ctx.identity);
    fail_group(t.ctx.group);
  }

  static const char* step_name(Op op) {
    switch (op) {
      case Op::switch_selective: return "switch-selective";
      case Op::slowscan_one: case Op::slowscan_loop: return "slowscan";
      case Op::configure_id: return "configure-node-id";
      case Op::store: return "store";
      case Op::identify_non_configured: return "identify-non-configured";
      case Op::fastscan_known: return "fastscan-known";
      case Op::fastscan_loop: return "fastscan";
      default: return "";
    }
  }

  void on_lss_result(const canopen::LssMaster::Result& r, TimePoint now) {
    if (!current) return;
    Task t = *current;
    current.reset();
    std::string dev = t.ctx.device.empty() && t.ctx.identity.serial == 0 ? (run ? run->device : "") : who(t.ctx);
    switch (t.op) {
      case Op::switch_selective: {
        timing("switch-selective", dev, r);
        if (!r.error) {
          if (t.ctx.target == 0) return;
          if (!t.ctx.candidates.empty()) t.ctx.identity = t.ctx.candidates[t.attempts];
          // The following tasks of this device carry the revision found.
          for (auto& x : tasks)
            if (x.ctx.group == t.ctx.group) x.ctx.identity = t.ctx.identity;
          return;
        }
        if (t.attempts + 1u < t.ctx.candidates.size()) {
          ++t.attempts;
          current = t;
          start_task(now);
          return;
        }
        if (!t.ctx.candidates.empty()) {
          // (a) with the revision unknown: Slowscan over every revision for this serial.
          Task s = make(Op::slowscan_one, t.ctx);
          s.range = LssRange{t.ctx.identity.vendor, t.ctx.identity.product, 0, 0xFFFFFFFFu, t.ctx.identity.serial,
                             t.ctx.identity.serial};
          tasks.push_front(s);
          return;
        }
        if (t.ctx.sdo_fallback) {
          start_sdo_fallback(t.ctx);
          return;
        }
        problem(who(t.ctx) + ": no answer to LSS switch selective (" + describe(t.ctx.identity) + ")", t.ctx.from,
                t.ctx.identity);
        std::erase_if(tasks, [g = t.ctx.group](const Task& x) { return x.ctx.group == g; });
        return;
      }
      case Op::slowscan_one: {
        timing("slowscan", dev, r);
        if (r.error) {
          current = t;
          fail_current("Slowscan found no device with " + describe(t.ctx.identity), now);
          return;
        }
        for (auto& x : tasks)
          if (x.ctx.group == t.ctx.group) x.ctx.identity = r.address;
        return;
      }
      case Op::slowscan_loop: {
        timing("slowscan", run ? run->device : dev, r);
        if (r.error) return;  // kNotFound: no more devices in the range
        const LssAddress a = r.address;
        std::vector<Task> v;
        const bool elsewhere = [&] {
          for (std::uint8_t x = 1; x <= 127; ++x)
            if (x != t.node)
              for (const auto& id : at(x).ids)
                if (same_device(id, a)) return true;
          return false;
        }();
        const bool done = run && run->handled.contains(a.serial);
        if (t.non_configured) {
          // (c) took every node-ID away: a device restore_known puts back is
          // left to it; any other gets its node-ID here.
          const bool known = run && std::any_of(run->known.begin(), run->known.end(),
                                                [&](const auto& k) { return same_device(k.first, a); });
          if (!known && !elsewhere) v = recover_non_configured(a, t.node);
        } else if (!elsewhere && !done) {
          if (run) run->handled.insert(a.serial);
          Decision d = decide(a);
          if (!d.problem.empty()) problem(d.problem, t.node, a);
          if (d.target != 0 && d.target != t.node && node_free_for(d.target, a)) {
            remember(a, d.target);
            Ctx c;
            c.identity = a;
            c.from = t.node;
            c.target = d.target;
            c.device = d.device;
            c.replaces = d.replaces;
            c.replaced = d.replaced;
            c.group = next_group++;
            v = assign_tasks(c);
          }
        }
        if (v.empty()) v.push_back(make_global(LssMode::kWaiting));
        if (a.serial < 0xFFFFFFFFu) {
          Task next = t;
          next.range.serial_lo = a.serial + 1;
          v.push_back(next);
        }
        push_front(std::move(v));
        return;
      }
      case Op::configure_id: {
        timing("configure-node-id", dev, r);
        if (r.error || r.slave_error != 0) {
          if (t.ctx.target == canopen::cob::kNodeIdUnconfigured) return;  // (c): nobody had to answer
          if (t.ctx.from == canopen::cob::kNodeIdUnconfigured)
            note_stranger(t.ctx.identity, "refuses LSS node-ID " + std::to_string(t.ctx.target) + " (" +
                                              (r.error ? r.error.message()
                                                       : "slave error " + std::to_string(r.slave_error)) +
                                              "); left non-configured");
          current = t;
          fail_current("LSS configure node-ID " + std::to_string(t.ctx.target) + " failed: " +
                           (r.error ? r.error.message() : "slave error " + std::to_string(r.slave_error)),
                       now);
          return;
        }
        if (t.ctx.boot_wait && canopen::cob::valid_node_id(t.ctx.target)) {
          BootWait w;
          w.ctx = t.ctx;
          w.registered = now;
          boot_waits.push_back(std::move(w));
        }
        return;
      }
      case Op::store: {
        timing("store", dev, r);
        if (r.error || r.slave_error != 0)
          problem(who(t.ctx) + ": LSS store configuration failed (" +
                      (r.error ? r.error.message() : "slave error " + std::to_string(r.slave_error)) +
                      "); node " + std::to_string(t.ctx.target) + " holds until the next power-off",
                  t.ctx.target, t.ctx.identity);
        return;
      }
      case Op::identify_non_configured: {
        if (r.answered) {
          timing("identify-non-configured", "", r);
          std::vector<Task> v = targeted_fastscans();
          if (now >= general_scan_not_before) {
            Task fs = make(Op::fastscan_loop);
            fs.node = 0;
            v.push_back(fs);
          }
          v.push_back(make(Op::wait_boots));
          push_front(std::move(v));
        }
        return;
      }
      case Op::fastscan_known: {
        timing("fastscan-known", t.ctx.device, r);
        if (r.error) return;  // not at FFh (or another product code of its model: the next task tries it)
        std::erase_if(tasks, [&](const Task& x) { return x.op == Op::fastscan_known && x.ctx.device == t.ctx.device; });
        bool stranger = false;
        push_front(place_non_configured(r.address, t, stranger));
        return;
      }
      case Op::fastscan_loop: {
        timing("fastscan", run ? run->device : "", r);
        if (r.error) {
          // Nobody left that Fastscan can find. A non-configured device
          // answered identify non-configured but Fastscan found none: it is of
          // the pre-Fastscan series (J, DSP-305 V1.1.2), which Slowscan finds.
          if (t.node == 0 && run && run->job.kind == Job::Kind::non_configured && run->found.empty() &&
              !run->slowscanned) {
            run->slowscanned = true;
            push_front(slowscan_all_pre_fastscan());
          }
          return;
        }
        const LssAddress a = r.address;
        if (is_stranger(a)) {
          // Fastscan finds the smallest address: the stranger again, so the
          // loop ends here, and the general scan backs off (the targeted
          // scans of configured devices still run every period).
          general_scan_backoff = std::min(2 * general_scan_backoff + std::chrono::seconds(bus.discovery_period_s),
                                          Duration{std::chrono::minutes(10)});
          general_scan_not_before = now + general_scan_backoff;
          push_front({make_global(LssMode::kWaiting)});
          return;
        }
        bool stranger = false;
        std::vector<Task> v = place_non_configured(a, t, stranger);
        if (!stranger) v.push_back(t);  // the next Fastscan
        push_front(std::move(v));
        return;
      }
      default: return;
    }
  }

  // A device Fastscan found at FFh: its tasks (node-ID, store, boot-up wait),
  // or, when nothing gives it a node-ID, a stranger left non-configured.
  std::vector<Task> place_non_configured(const LssAddress& a, const Task& t, bool& stranger) {
    if (run) run->found.push_back(a);
    const Ctx c = found_ctx(a, t.node);
    stranger = c.target == 0;
    if (!stranger) return assign_tasks(c);
    note_stranger(a, "not in the configuration; left without node-ID");
    return {make_global(LssMode::kWaiting)};
  }

  // Where a device found at FFh goes: back where (c) took it from, its
  // configured / remembered node-ID, or nowhere (target 0).
  Ctx found_ctx(const LssAddress& a, std::uint8_t scan_node) {
    Ctx c;
    c.identity = a;
    c.from = canopen::cob::kNodeIdUnconfigured;
    c.group = next_group++;
    std::optional<std::uint8_t> known;
    if (run)
      for (const auto& [id, node] : run->known)
        if (same_device(id, a)) known = node;
    if (known) {
      c.target = *known;
      const auto at = present_at(a);
      c.store = !at || *at != c.target;  // unchanged node-IDs need no store (flash wear)
      c.boot_wait = c.store;
      if (at) c.from = *at;
      return c;
    }
    discovery::Placement p = place(a, scan_node, true);
    Decision& d = p.decision;
    c.device = d.device;
    c.replaces = d.replaces;
    c.replaced = d.replaced;
    c.target = p.target;
    switch (p.via) {
      case discovery::Placement::Via::decision:
        if (scan_node != 0) c.from = scan_node;
        break;
      case discovery::Placement::Via::back:
        // (c) made it non-configured; an unknown device goes back where it was, unstored.
        c.store = false;
        c.boot_wait = false;
        break;
      case discovery::Placement::Via::none:
        if (p.pool_exhausted) note_stranger(a, "not in the configuration and no free node-ID left in node_pool");
        break;
      case discovery::Placement::Via::pool: break;
    }
    if (!d.problem.empty()) problem(d.problem, 0, a);
    if (c.target != 0) remember(a, c.target);
    return c;
  }

  discovery::Placement place(const LssAddress& a, std::uint8_t back_to, bool unknown_policy) {
    discovery::Placement p = discovery::place_non_configured(a, back_to, unknown_policy, input(picture()));
    apply(p.decision.effects);
    return p;
  }

  // ---- devices nobody configured -------------------------------------------
  // A non-configured device the configuration does not name (or one that
  // refuses its node-ID) is reported once with its identity and remembered,
  // so that Fastscan, which always finds the smallest address first, is not
  // run for it again and again; configured devices are found by their known
  // identity meanwhile (targeted_fastscans).

  [[nodiscard]] bool is_stranger(const LssAddress& a) const {
    return std::any_of(strangers.begin(), strangers.end(), [&](const LssAddress& s) { return same_device(s, a); });
  }

  void note_stranger(const LssAddress& a, const std::string& why) {
    if (is_stranger(a)) return;
    strangers.push_back(a);
    problem("non-configured " + describe(a) + ": " + why, 0, a);
    DiscoveryEvent e;
    e.kind = DiscoveryEventKind::identified;
    e.node_id = canopen::cob::kNodeIdUnconfigured;
    e.identity = a;
    e.text = why;
    events.push_back(std::move(e));
  }

  static canopen::LssMaster::FastscanKnown known_fields(const LssAddress& a) {
    canopen::LssMaster::FastscanKnown k;
    k.vendor = a.vendor;
    if (a.product != 0) k.product = a.product;
    if (a.revision != 0) k.revision = a.revision;
    k.serial = a.serial;
    return k;
  }

  // One Fastscan per configured device of this bus that is not present and
  // whose serial and vendor are known (config, or its model), per product
  // code its model may report: each confirms whole fields (BitChecked 0)
  // instead of searching 128 bits, and a stranger never answers them.
  [[nodiscard]] std::vector<Task> targeted_fastscans() const {
    std::vector<Task> v;
    for (const auto& c : devices) {
      if (c.serial == 0 || is_present_serial(c.serial)) continue;
      const config::KnownModel* m = c.model.empty() ? nullptr : config::find_model(c.model);
      const std::optional<std::uint32_t> vendor = c.vendor ? c.vendor : m ? std::optional(m->vendor) : std::nullopt;
      if (!vendor) continue;
      std::vector<std::uint32_t> products;
      if (c.product) products.push_back(*c.product);
      else if (m) products.assign(m->products.begin(), m->products.end());
      if (products.empty()) products.push_back(0);  // unknown: searched
      for (const std::uint32_t product : products) {
        Ctx ctx;
        ctx.identity = LssAddress{*vendor, product, 0, c.serial};
        ctx.device = c.name;
        v.push_back(make(Op::fastscan_known, ctx));
      }
    }
    return v;
  }

  [[nodiscard]] bool is_present_serial(std::uint32_t serial) const {
    for (std::uint8_t x = 1; x <= 127; ++x)
      for (const auto& id : at(x).ids)
        if (id.serial == serial) return true;
    return false;
  }

  // A device found by Slowscan while non-configured (pre-Fastscan series
  // after (c), or left so by an earlier run): its target node-ID, else back
  // to the node it came from (`from`, 0 = none), not stored.
  std::vector<Task> recover_non_configured(const LssAddress& a, std::uint8_t from) {
    if (run) {
      run->handled.insert(a.serial);
      run->found.push_back(a);
    }
    Ctx c;
    c.identity = a;
    c.from = canopen::cob::valid_node_id(from) ? from : canopen::cob::kNodeIdUnconfigured;
    c.group = next_group++;
    const discovery::Placement p = place(a, from, false);
    const Decision& d = p.decision;
    c.device = d.device;
    c.replaces = d.replaces;
    c.replaced = d.replaced;
    if (!d.problem.empty()) problem(d.problem, from, a);
    if (p.via == discovery::Placement::Via::none) {
      problem("non-configured " + describe(a) + " left without node-ID", 0, a);
      return {};
    }
    c.target = p.target;
    if (p.via == discovery::Placement::Via::back) {
      c.store = false;
      c.boot_wait = false;
    }
    remember(a, c.target);
    return assign_tasks(c);
  }

  void start_sdo_fallback(const Ctx& c0) {
    const auto obj = sdo_node_id_object(c0.identity);
    Ctx c = c0;
    std::erase_if(tasks, [g = c.group](const Task& x) { return x.ctx.group == g; });
    std::vector<Task> v;
    Task w = make(Op::sdo_write, c);
    w.node = c.from;
    w.index = obj->index;
    w.sub = 0;
    w.value = static_cast<std::uint32_t>(c.target - obj->minus);
    w.len = 1;
    v.push_back(w);
    Task s = make(Op::sdo_write, c);
    s.node = c.from;
    s.index = kStoreObject;
    s.sub = obj->save_sub;
    s.value = discovery::kSaveSignature;
    s.len = 4;
    v.push_back(s);
    v.push_back(make_nmt(canopen::NmtCommand::reset_node, c.from, c.group));
    push_front(std::move(v));
  }

  void on_sdo_done(TimePoint now, std::error_code err) {
    Task t = *current;
    current.reset();
    sdo.reset();
    const std::string step = t.index == kStoreObject ? "sdo-save" : "sdo-node-id";
    timing(step, who(t.ctx), now - current_started);
    if (err) {
      const bool timed_out = err == make_error_code(canopen::SdoAbort::kProtocolTimedOut);
      current = t;
      fail_current("SDO write " + hex32(t.index).substr(6) + "/" + std::to_string(t.sub) + " failed (" +
                       (timed_out ? std::string("timeout") : "abort " + hex32(static_cast<std::uint32_t>(err.value()))) +
                       ")",
                   now);
      return;
    }
    if (t.index != kStoreObject && t.ctx.boot_wait) {
      BootWait w;
      w.ctx = t.ctx;
      w.registered = now;
      boot_waits.push_back(std::move(w));
    }
  }

  void finish_wait_boots(TimePoint) {
    current.reset();
    for (const auto& w : boot_waits)
      if (!w.seen)
        problem(who(w.ctx) + ": no boot-up at node " + std::to_string(w.ctx.target) + " after the reset",
                w.ctx.target, w.ctx.identity);
    boot_waits.clear();
  }

  bool drive_tasks(TimePoint now) {
    if (current) {
      switch (current->op) {
        case Op::settle:
          if (now >= task_deadline) current.reset();
          return !current;
        case Op::sdo_write:
          if (retry_start) {
            if (now < task_deadline) return false;
            retry_start = false;
            start_task(now);
            return true;
          }
          task_deadline = sdo->process(now);
          if (auto r = sdo->take_result()) on_sdo_done(now, r->error);
          return !current;
        case Op::wait_boots: {
          const bool all = std::all_of(boot_waits.begin(), boot_waits.end(), [](const BootWait& w) { return w.seen; });
          if (all || now >= task_deadline) finish_wait_boots(now);
          return !current;
        }
        default:
          if (retry_start && now >= task_deadline) {
            retry_start = false;
            start_task(now);
            return true;
          }
          return false;  // an LSS operation: its result comes through on_lss_result
      }
    }
    if (tasks.empty()) {
      if (probe.active() || !may_commission() || jobs.empty()) {
        if (jobs.empty() && bus.commissioning == config::Commissioning::manual) permit = false;
        return false;
      }
      const Job j = jobs.front();
      jobs.erase(jobs.begin());
      expand(j, now);
      return true;
    }
    current = std::move(tasks.front());
    tasks.pop_front();
    start_task(now);
    return true;
  }

  TimePoint process(TimePoint now) {
    if (!started) return kNever;
    for (int guard = 0; guard < 1000; ++guard) {
      bool progress = false;
      handle_bootups(now);
      flush();
      (void)lss.process(now);
      if (auto r = lss.take_result()) {
        on_lss_result(*r, now);
        progress = true;
      }
      if (bus.discovery && next_periodic != kNever && now >= next_periodic && !probe.active() && tasks.empty() &&
          !current) {
        next_periodic = now + std::chrono::seconds(bus.discovery_period_s);
        start_periodic_probe(now);
        progress = true;
      }
      // Probes of boot-ups run beside the commissioning tasks; probing while
      // devices are being reset would only see half the picture otherwise.
      if (drive_probe(now)) progress = true;
      if (presence_changed && !probe.active()) {
        reevaluate();
        progress = true;
      }
      if (drive_tasks(now)) progress = true;
      if (!progress) break;
    }
    TimePoint next = lss.process(now);
    if (!outbox.empty()) next = std::min(next, now + std::chrono::milliseconds(1));
    next = std::min(next, probe.next_deadline(now));
    if (current) next = std::min(next, task_deadline);
    // A periodic probe that is due waits for the commissioning to finish,
    // whose own deadlines bring us back.
    if (bus.discovery && next_periodic > now) next = std::min(next, next_periodic);
    return std::max(next, now);
  }
};

Discovery::Discovery(can::FrameSink& sink, const config::Config& config, std::size_t bus_index,
                     std::vector<Assignment> previous, DiscoveryOptions options)
    : impl_(std::make_unique<Impl>(sink, config, bus_index, std::move(previous), options)) {}

Discovery::~Discovery() = default;

void Discovery::start(TimePoint now) {
  Impl& d = *impl_;
  if (d.started) return;
  d.started = true;
  if (d.bus.discovery) {
    d.next_periodic = now + std::chrono::seconds(d.bus.discovery_period_s);
    d.start_full_probe(now);
  }
}

bool Discovery::on_frame(const can::Frame& frame, TimePoint now) noexcept { return impl_->on_frame(frame, now); }

TimePoint Discovery::process(TimePoint now) { return impl_->process(now); }

void Discovery::request_commission() {
  Impl& d = *impl_;
  if (d.bus.commissioning == config::Commissioning::off) return;
  d.permit = true;
  d.queue_job(Impl::Job{Impl::Job::Kind::non_configured, 0});
}

void Discovery::reload(const config::Config& config, std::size_t bus_index, std::vector<Assignment> previous) {
  impl_->apply_config(config, bus_index, std::move(previous));
}

void Discovery::set_supervised(std::uint8_t node_id, bool supervised) noexcept {
  if (!canopen::cob::valid_node_id(node_id)) return;
  Impl& d = *impl_;
  discovery::NodePicture& node = d.probe.node(node_id);
  if (node.supervised == supervised) return;
  node.supervised = supervised;
  d.presence_changed = true;
  if (!supervised) {
    // Heartbeat lost (or no longer watched): what the last probe saw there
    // may be gone. Ask now rather than at the next periodic probe, so that
    // a replacement waiting for this device's place is decided soon.
    node.unsure = true;
    d.request_probe(node_id);
  }
}

std::error_code record_assignment(StateStore& store, const std::string& bus, const DiscoveryEvent& e) {
  const bool stores = e.kind == DiscoveryEventKind::commissioned ||
                      (e.kind == DiscoveryEventKind::identified && e.at_target && !e.device.empty());
  if (!stores || !canopen::cob::valid_node_id(e.node_id)) return {};
  std::error_code first;
  if (!e.replaces.empty() && e.replaced.serial != 0 && !same_device(e.replaced, e.identity)) {
    // The replaced device's vendor/product may be unknown (0): any line of
    // that serial on this bus that fits what is known.
    for (const auto& old : store.on_bus(bus)) {
      if (old.serial != e.replaced.serial) continue;
      if (e.replaced.vendor != 0 && old.vendor != e.replaced.vendor) continue;
      if (e.replaced.product != 0 && old.product != e.replaced.product) continue;
      if (auto ec = store.erase(bus, old.vendor, old.product, old.serial); ec && !first) first = ec;
    }
  }
  Assignment a;
  a.bus = bus;
  a.serial = e.identity.serial;
  a.vendor = e.identity.vendor;
  a.product = e.identity.product;
  a.revision = e.identity.revision;
  a.node_id = e.node_id;
  if (const auto old = store.find(bus, a.vendor, a.product, a.serial)) a.fingerprint = old->fingerprint;
  if (auto ec = store.put(a); ec && !first) first = ec;
  return first;
}

std::vector<DiscoveryEvent> Discovery::take_events() { return std::exchange(impl_->events, {}); }
std::vector<StepTiming> Discovery::take_timings() { return std::exchange(impl_->timings, {}); }

bool Discovery::commissioning() const noexcept {
  const Impl& d = *impl_;
  // Looking for non-configured devices (Fastscan, node-ID for what it finds)
  // touches only slaves at FFh: configured devices may be configured meanwhile,
  // so a stranger's scan never holds them up.
  const bool only_non_configured = d.run && d.run->job.kind == Impl::Job::Kind::non_configured;
  return (d.current.has_value() || !d.tasks.empty()) && !only_non_configured;
}

bool Discovery::commission_pending() const noexcept {
  const Impl& d = *impl_;
  return !d.jobs.empty() && !d.may_commission() && d.bus.commissioning != config::Commissioning::off &&
         std::any_of(d.jobs.begin(), d.jobs.end(),
                     [](const Impl::Job& j) { return j.kind != Impl::Job::Kind::non_configured; });
}

std::vector<Discovery::NodeView> Discovery::nodes() const {
  std::vector<NodeView> out;
  const Impl& d = *impl_;
  for (std::uint8_t n = 1; n <= 127; ++n) {
    const auto& node = d.at(n);
    if (node.ids.empty() && !node.clash) continue;
    NodeView v;
    v.node_id = n;
    v.identities = node.ids;
    if (!node.ids.empty()) {
      if (auto t = d.assigned_to(node.ids[0])) v.target_node_id = *t;
      if (const auto* c = d.configured_by_serial(node.ids[0].serial)) v.device = c->name;
      for (const auto& w : d.session.swapped)
        if (same_device(w.by, node.ids[0])) v.device = w.name;
    }
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace cobridge::gateway
