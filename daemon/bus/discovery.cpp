// Discovery: see discovery.hpp. The facade that ties the procedures
// together in process(): the identity probe (discovery/identity_probe) finds
// who is where, node-ID assignment (discovery/node_assignment, applied by
// discovery/decisions) decides where each must be, and commissioning
// (discovery/commissioning, with the Fastscan search of
// discovery/fastscan_search) moves them there. Here: what an identified
// device means for the bus manager (`identified` events, move jobs), and the
// unknown devices decided again when the presence picture changes.
#include "bus/discovery.hpp"

#include "canopen/cob_id.hpp"
#include "device/eds.hpp"
#include "bus/discovery/commissioning.hpp"
#include "bus/discovery/decisions.hpp"
#include "bus/discovery/identity_probe.hpp"
#include "bus/discovery/report.hpp"

#include <algorithm>
#include <bitset>
#include <utility>

namespace cobridge::bus {

using canopen::Duration;
using canopen::kNever;
using canopen::LssAddress;
using canopen::TimePoint;
using discovery::Decision;
using discovery::describe;
using discovery::Job;
using discovery::same_device;

// The start-up probe of the node-IDs where devices are expected ends this
// long after its requests at the latest; what did not answer by then is
// asked again in the full probe, with the SDO timeout.
constexpr Duration kExpectedAnswerWindow = std::chrono::milliseconds(50);

const char* to_string(DiscoveryEventKind k) noexcept {
  switch (k) {
    case DiscoveryEventKind::identified: return "identified";
    case DiscoveryEventKind::commissioned: return "commissioned";
    case DiscoveryEventKind::clash_detected: return "clash-detected";
    case DiscoveryEventKind::clash_resolved: return "clash-resolved";
    case DiscoveryEventKind::problem: return "problem";
    case DiscoveryEventKind::retry: return "retry";
  }
  return "?";
}

struct Discovery::Impl final : discovery::ProbeListener {
  discovery::BusSettings s;
  discovery::Report report;
  discovery::IdentityProbe probe;
  discovery::Decisions decisions;
  discovery::Commissioning work;
  bool started = false;
  TimePoint next_periodic = kNever;
  // Start-up: the round of the expected node-IDs runs, then the rest of 1..127.
  std::bitset<128> expected;
  bool expected_round = false;
  bool rest_pending = false;

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
  // Node-IDs must not be assigned (hold_assignments): the policy the
  // configuration gives is kept here while s.bus says off.
  std::string hold;
  config::Commissioning configured_policy = config::Commissioning::automatic;

  Impl(can::FrameSink& sink, const config::Config& config, std::size_t bus_index, std::vector<Assignment> prev,
       DiscoveryOptions o)
      : probe(sink, o),
        decisions(s, probe),
        work(sink, s, decisions, probe, report, lss_config_of(config.buses.at(bus_index), o)) {
    s.opt = o;
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

  // Devices described by an EDS file and configured without vendor or model:
  // the file's VendorNumber (checked against the configuration at start-up),
  // so that Fastscan confirms it whole. Read at (re)load, off the frame path.
  static std::vector<std::pair<std::uint32_t, std::uint32_t>> eds_vendors(const std::vector<config::Device>& devices) {
    std::vector<std::pair<std::uint32_t, std::uint32_t>> out;
    for (const auto& d : devices) {
      if (d.vendor || !d.model.empty() || d.eds.empty()) continue;
      const device::EdsResult r = device::load_eds_file(d.eds);
      if (r.ok() && r.description->device_info.vendor_number != 0)
        out.emplace_back(d.serial, r.description->device_info.vendor_number);
    }
    return out;
  }

  // A reload keeps the LSS master (and its timeout): it may be mid-operation.
  void apply_config(const config::Config& config, std::size_t bus_index, std::vector<Assignment> prev) {
    s.bus = config.buses.at(bus_index);
    configured_policy = s.bus.commissioning;
    if (!hold.empty()) s.bus.commissioning = config::Commissioning::off;
    s.devices.clear();
    for (const auto& d : config.devices)
      if (d.bus_index == bus_index) s.devices.push_back(d);
    s.previous = std::move(prev);
    s.eds_vendors = eds_vendors(s.devices);
    s.sdo_timeout = s.opt.sdo_timeout != Duration{} ? s.opt.sdo_timeout : std::chrono::milliseconds(s.bus.sdo_timeout_ms);
    s.lss_timeout = lss_timeout_of(s.bus, s.opt);
    probe.set_sdo_timeout(s.sdo_timeout);
    probe.set_enabled(s.bus.discovery && started);
  }

  [[nodiscard]] const discovery::NodePicture& at(std::uint8_t n) const { return probe.picture()[n]; }

  // ---- frames in ---------------------------------------------------------
  bool on_frame(const can::Frame& f, TimePoint now) noexcept {
    if (f.is_extended() || f.is_rtr() || f.is_error()) return false;
    if (f.id == canopen::cob::kLssSlaveToMaster) return work.on_lss_frame(f, now);
    if (f.id > canopen::cob::kSdoTxBase && f.id <= canopen::cob::kSdoTxBase + 127 && f.len == 8) {
      bool used = probe.on_sdo_answer(f, now);
      if (work.on_sdo_frame(f, now)) used = true;
      return used;
    }
    if (f.id > canopen::cob::kNmtErrorControlBase && f.id <= canopen::cob::kNmtErrorControlBase + 127 && f.len == 1) {
      probe.on_error_control(f, now, work.quiet(now));
      return true;
    }
    return false;
  }

  // ---- probe results -------------------------------------------------------
  void on_probed(const discovery::ProbeResult& r) override {
    using Kind = discovery::ProbeResult::Kind;
    const std::uint8_t n = r.node;
    if (r.changed) decisions.presence_changed = true;
    switch (r.kind) {
      case Kind::nobody:
        work.clash_settled(n);
        if (r.was_known) std::erase_if(reported_ids, [n](const Reported& x) { return x.node == n; });
        std::erase_if(unplaced, [n](const Unplaced& u) { return u.node == n; });
        return;
      case Kind::refused:
        report.problem("node " + std::to_string(n) + " answers SDO but refuses to read its identity 0x1018", n);
        return;
      case Kind::incomplete: return;
      case Kind::identified: {
        const LssAddress a = at(n).ids[0];
        std::erase_if(unplaced, [&](const Unplaced& u) { return u.node == n && !same_device(u.id, a); });
        work.clash_settled(n);
        // The start-up probe decides once every node has answered (swaps need
        // to know which configured devices are missing); a configured device
        // at its own node-ID depends on no such decision.
        if ((r.full || expected_round) && !decisions.initial_probe_done && !configured_at(n, a)) return;
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
      report.event(std::move(e));
    }
    work.clash_persists(n, r.count);
  }

  void on_round_end(bool full, Duration took) override {
    report.timing(full ? "probe" : expected_round ? "probe-expected" : "probe-nodes", "", took);
    if (expected_round) {
      // The rest of 1..127; an expected node that did not answer within the
      // short window is asked again with the full SDO timeout.
      expected_round = false;
      rest_pending = true;
      return;
    }
    if (!full) return;
    if (!decisions.initial_probe_done) {
      decisions.initial_probe_done = true;
      // Decided only now that every configured device had its chance to
      // answer, so that a swap never takes the place of a present device.
      for (std::uint8_t n = 1; n <= 127; ++n)
        if (at(n).ids.size() == 1 && !at(n).clash) on_identified(n, at(n).ids[0], false);
    }
    work.queue(Job{Job::Kind::non_configured, 0});
  }

  // ---- decisions -----------------------------------------------------------
  void on_identified(std::uint8_t n, const LssAddress& a, bool bootup) {
    const Decision d = decisions.decide(a);
    std::erase_if(unplaced, [n](const Unplaced& u) { return u.node == n; });
    if (d.wait) {
      // Reported once the probe it waits for has told whether the
      // configured device is still there.
      unplaced.push_back(Unplaced{n, a, bootup, true});
      return;
    }
    if (d.device.empty()) unplaced.push_back(Unplaced{n, a, false, false});
    if (d.target != 0) decisions.remember(a, d.target);
    if (d.target == n) work.at_target(a);
    report_identified(n, a, d, bootup);
    if (!d.problem.empty()) report.problem(d.problem, n, a);
    if (d.target != 0 && d.target != n) {
      if (!decisions.node_free_for(d.target, a)) {
        report.problem("node " + std::to_string(d.target) + " for " + d.device + " is held by another device; " +
                           d.device + " stays at node " + std::to_string(n),
                       n, a);
        return;
      }
      work.queue(Job{Job::Kind::move, n});
    }
  }

  void report_identified(std::uint8_t n, const LssAddress& a, const Decision& d, bool bootup) {
    auto it = std::find_if(reported_ids.begin(), reported_ids.end(), [n](const Reported& r) { return r.node == n; });
    const bool changed = it == reported_ids.end() || it->id != a || it->device != d.device || it->target != d.target;
    if (!changed && !bootup) return;
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
    report.event(std::move(e));
  }

  // The presence picture changed: decide the unknown devices (and those
  // waiting for a probe) again. Between probe rounds only, so that no
  // decision rests on half a round.
  void reevaluate() {
    decisions.presence_changed = false;
    std::vector<Unplaced> list = std::exchange(unplaced, {});
    for (const Unplaced& u : list) {
      const discovery::NodePicture& node = at(u.node);
      // Gone or changed: the probe that saw it has reported it already.
      if (node.clash || node.ids.size() != 1 || !same_device(node.ids[0], u.id)) continue;
      on_identified(u.node, u.id, u.pending && u.bootup);
    }
  }

  // ---- the loop --------------------------------------------------------------
  void start_periodic_probe(TimePoint now) {
    std::bitset<128> v;
    for (std::uint8_t n = 1; n <= 127; ++n)
      if (!at(n).supervised && !work.busy(n)) v.set(n);
    probe.begin(now, true, v);
  }

  bool drive_probe(TimePoint now) {
    if (probe.active()) return probe.drive(now, *this);
    if (rest_pending) {
      rest_pending = false;
      std::bitset<128> rest;
      for (std::uint8_t n = 1; n <= 127; ++n)
        if (!expected[n] || (at(n).ids.empty() && !at(n).clash)) rest.set(n);
      probe.begin(now, true, rest);
      return true;
    }
    // Probes wait while commissioning resets devices or makes them
    // non-configured: half a picture would start wrong work. A search for
    // non-configured devices (LSS at FFh) resets nobody: devices it moved
    // are probed (and configured) while it goes on.
    if (!probe.requested() || work.resetting()) return false;
    probe.begin(now, false);
    return true;
  }

  // Start-up: the node-IDs where devices are expected (configured, or
  // remembered from the state file) first. Devices there answer within
  // milliseconds, so they are identified, and configured, without waiting
  // out the SDO timeout of the empty node-IDs; the rest follows at once.
  void start_probe(TimePoint now) {
    expected.reset();
    for (const auto& c : s.devices)
      if (c.node_id) expected.set(*c.node_id);
    for (const auto& p : s.previous)
      if (canopen::cob::valid_node_id(p.node_id)) expected.set(p.node_id);
    if (expected.none()) {
      probe.begin(now, true, std::bitset<128>{}.set().reset(0));
      return;
    }
    expected_round = true;
    probe.begin(now, false, expected, kExpectedAnswerWindow);
  }

  // A configured device (serial, model) at the node-ID it must have.
  [[nodiscard]] bool configured_at(std::uint8_t n, const LssAddress& a) const {
    const config::Device* c = decisions.configured_by_serial(a.serial);
    if (c == nullptr || !discovery::model_matches(*c, a, false)) return false;
    if (c->node_id) return *c->node_id == n;
    return std::any_of(s.previous.begin(), s.previous.end(),
                       [&](const Assignment& p) { return p.serial == a.serial && p.vendor == a.vendor && p.node_id == n; });
  }

  void handle_bootups(TimePoint now) {
    const std::bitset<128> booted = probe.take_bootups();
    if (booted.none()) return;
    work.on_bootups(booted, now);
    // Every boot-up is followed by a probe: a swapped part never silently
    // inherits the old one's settings.
    for (std::uint8_t n = 1; n <= 127; ++n)
      if (booted[n]) probe.want(n, true);
  }

  TimePoint process(TimePoint now) {
    if (!started) return kNever;
    for (int guard = 0; guard < 1000; ++guard) {
      bool progress = false;
      handle_bootups(now);
      if (work.poll_lss(now)) progress = true;
      if (s.bus.discovery && next_periodic != kNever && now >= next_periodic && !probe.active() && work.idle()) {
        next_periodic = now + std::chrono::seconds(s.bus.discovery_period_s);
        start_periodic_probe(now);
        progress = true;
      }
      // Probes of boot-ups run beside the commissioning tasks; probing while
      // devices are being reset would only see half the picture otherwise.
      if (drive_probe(now)) progress = true;
      if (decisions.presence_changed && !probe.active()) {
        reevaluate();
        progress = true;
      }
      if (work.drive(now, probe.active())) progress = true;
      if (!progress) break;
    }
    TimePoint next = std::min(work.next_deadline(now), probe.next_deadline(now));
    // A periodic probe that is due waits for the commissioning to finish,
    // whose own deadlines bring us back.
    if (s.bus.discovery && next_periodic > now) next = std::min(next, next_periodic);
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
  d.probe.set_enabled(d.s.bus.discovery);
  if (d.s.bus.discovery) {
    d.next_periodic = now + std::chrono::seconds(d.s.bus.discovery_period_s);
    d.start_probe(now);
  }
}

bool Discovery::on_frame(const can::Frame& frame, TimePoint now) noexcept { return impl_->on_frame(frame, now); }

TimePoint Discovery::process(TimePoint now) { return impl_->process(now); }

void Discovery::request_commission() { impl_->work.request(); }

void Discovery::hold_assignments(std::string why) {
  Impl& d = *impl_;
  d.hold = std::move(why);
  d.s.bus.commissioning = d.hold.empty() ? d.configured_policy : config::Commissioning::off;
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
  d.decisions.presence_changed = true;
  if (!supervised) {
    // Heartbeat lost (or no longer watched): what the last probe saw there
    // may be gone. Ask now rather than at the next periodic probe, so that
    // a replacement waiting for this device's place is decided soon.
    node.unsure = true;
    d.probe.request(node_id);
  }
}

Error record_assignment(StateStore& store, const std::string& bus, const DiscoveryEvent& e) {
  const bool stores = e.kind == DiscoveryEventKind::commissioned ||
                      (e.kind == DiscoveryEventKind::identified && e.at_target && !e.device.empty());
  if (!stores || !canopen::cob::valid_node_id(e.node_id)) return {};
  Error first;
  if (!e.replaces.empty() && e.replaced.serial != 0 && !same_device(e.replaced, e.identity)) {
    // The replaced device's vendor/product may be unknown (0): any line of
    // that serial on this bus that fits what is known.
    for (const auto& old : store.on_bus(bus)) {
      if (old.serial != e.replaced.serial) continue;
      if (e.replaced.vendor != 0 && old.vendor != e.replaced.vendor) continue;
      if (e.replaced.product != 0 && old.product != e.replaced.product) continue;
      if (Error err = store.erase(bus, old.vendor, old.product, old.serial); err && !first) first = std::move(err);
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
  if (Error err = store.put(a); err && !first) first = std::move(err);
  return first;
}

std::vector<DiscoveryEvent> Discovery::take_events() { return impl_->report.take_events(); }
std::vector<StepTiming> Discovery::take_timings() { return impl_->report.take_timings(); }

bool Discovery::commissioning() const noexcept { return impl_->work.resetting(); }

bool Discovery::commission_pending() const noexcept { return impl_->work.pending(); }

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
      if (auto t = d.decisions.assigned_to(node.ids[0])) v.target_node_id = *t;
      if (const auto* c = d.decisions.configured_by_serial(node.ids[0].serial)) v.device = c->name;
      for (const auto& w : d.decisions.session().swapped)
        if (same_device(w.by, node.ids[0])) v.device = w.name;
    }
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace cobridge::bus
