// Discovery on a broadcast test bus (can::VirtualBus) with a fake clock and
// scripted devices built from SdoServer + ObjectDictionary + LssSlave, one
// per family: Novotechnik rotary (J, LSS V1.1.2: no Fastscan), Novotechnik
// multiturn (E, LSS V3) and ifm RM (F, LSS undocumented).
#include "bus/discovery.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "can/virtual_bus.hpp"
#include "canopen/cob_id.hpp"
#include "canopen/lss_slave.hpp"
#include "canopen/nmt.hpp"
#include "canopen/object_dictionary.hpp"
#include "canopen/sdo_server.hpp"
#include "config/config.hpp"
#include "device/eds.hpp"
#include "device/sim_device.hpp"
#include "bus/state_store.hpp"
#include "unit/device/source_paths.hpp"

namespace cobridge::bus {
namespace {

using namespace std::chrono_literals;
using canopen::DataType;
using canopen::LssAddress;
using canopen::TimePoint;

constexpr std::uint32_t kNovotechnik = 0x182;
constexpr std::uint32_t kIfm = 0x0069666D;
constexpr std::uint32_t kRfc4800 = 0x0BE0;
constexpr std::uint32_t kRsa3200 = 0x0BF3;
constexpr std::uint32_t kMultiturn = 0x0BB8;
constexpr std::uint32_t kMz1V02 = 0x0BD5;
constexpr std::uint32_t kIfmProduct = 0x4341;

enum class Kind { rotary, multiturn, ifm };

// A scripted encoder: answers SDO (0x1018, node-ID object, 0x1010 'save'),
// LSS, and NMT reset node / reset communication; sends its boot-up.
class TestDevice {
 public:
  TestDevice(can::VirtualBus& bus, Kind kind, LssAddress id, std::uint8_t node, bool lss = true,
             std::optional<canopen::LssSlaveFeatures> lss_features = {})
      : port_(bus.attach()), kind_(kind), lss_enabled_(lss) {
    (void)lss_frames_seen_;
    add(0x1018, 1, id.vendor, DataType::kUnsigned32, canopen::Access::kRo);
    add(0x1018, 2, id.product, DataType::kUnsigned32, canopen::Access::kRo);
    add(0x1018, 3, id.revision, DataType::kUnsigned32, canopen::Access::kRo);
    add(0x1018, 4, id.serial, DataType::kUnsigned32, canopen::Access::kRo);
    for (std::uint8_t s = 1; s <= 4; ++s) add(0x1010, s, 1, DataType::kUnsigned32, canopen::Access::kRw);
    const std::uint8_t raw = kind == Kind::ifm ? static_cast<std::uint8_t>(node - 1) : node;
    add(node_object(), 0, raw, DataType::kUnsigned8, canopen::Access::kRw);
    canopen::Hooks save;
    save.after_write = [this](std::uint16_t, std::uint8_t sub) {
      // F§6.3.3: ifm 0x1010/1; J§1.6.1 / E§11: Novotechnik node-ID with 0x1010/4.
      if (sub == (kind_ == Kind::ifm ? 1 : 4)) saved_sdo_node_ = sdo_node();
    };
    EXPECT_FALSE(od_.set_hooks(0x1010, save));
    canopen::Hooks node_written;
    node_written.after_write = [this](std::uint16_t, std::uint8_t) { sdo_pending_ = sdo_node(); };
    EXPECT_FALSE(od_.set_hooks(node_object(), 0, node_written));
    sdo_ = std::make_unique<canopen::SdoServer>(port_, od_, valid(node) ? node : 1);
    sdo_->set_enabled(valid(node));
    const auto features = lss_features ? *lss_features
                          : kind == Kind::rotary ? canopen::LssSlaveFeatures::rotary_j()
                                                 : canopen::LssSlaveFeatures::multiturn_e();
    lss_ = std::make_unique<canopen::LssSlave>(port_, id, node, features);
    lss_->set_store_handler([this](const canopen::LssSlave& s) {
      ++lss_stores_;
      stored_node_ = s.pending_node_id();
      return canopen::LssStoreError::kOk;
    });
    node_ = node;
  }

  void power_on() {
    if (valid(node_)) (void)port_.send(canopen::make_boot_up(node_));
  }

  void pump(TimePoint now) {
    can::Frame f;
    while (port_.receive(f)) {
      if (unplugged_) continue;  // off the bus: hears and says nothing
      if (f.id == canopen::cob::kNmt) {
        const auto p = canopen::parse_nmt(f);
        if (p.ok() && (p.frame.node == 0 || (valid(node_) && p.frame.node == node_)) &&
            (p.frame.command == canopen::NmtCommand::reset_comm ||
             p.frame.command == canopen::NmtCommand::reset_node))
          reset();
        continue;
      }
      if (f.id == canopen::cob::kLssMasterToSlave) {
        if (f.data[0] == static_cast<std::uint8_t>(canopen::LssCs::kConfigureNodeId) && ignore_configure_node_id > 0) {
          --ignore_configure_node_id;  // lost on the wire: no answer
          continue;
        }
        if (lss_enabled_ && answer_lss) {
          ++lss_frames_seen_;
          lss_->on_frame(f);
          // CiA 305 V3: leaving configuration with a new node-ID while
          // non-configured resets communication by itself.
          if (lss_->take_reset_communication_request()) reset();
        }
        continue;
      }
      if (answer_sdo) sdo_->on_frame(f, now);
    }
  }
  bool answer_sdo = true;  // false: its SDO answers are lost (collided on the wire)
  bool answer_lss = true;  // false: LSS requests do not reach it (it hears and says nothing)
  unsigned ignore_configure_node_id = 0;  // so many LSS configure node-ID requests are lost
  // Taken off the bus (a technician removes it): silent from now on.
  void unplug() { unplugged_ = true; }

  [[nodiscard]] std::uint8_t node() const { return node_; }
  [[nodiscard]] bool pending() const { return port_.pending() > 0; }
  [[nodiscard]] std::uint32_t lss_stores() const { return lss_stores_; }
  [[nodiscard]] std::optional<std::uint8_t> stored_node() const { return stored_node_; }
  [[nodiscard]] std::optional<std::uint8_t> saved_sdo_node() const { return saved_sdo_node_; }
  [[nodiscard]] std::uint32_t resets() const { return resets_; }

 private:
  static bool valid(std::uint8_t n) { return canopen::cob::valid_node_id(n); }
  [[nodiscard]] std::uint16_t node_object() const { return kind_ == Kind::ifm ? 0x3000 : 0x2000; }
  [[nodiscard]] std::uint8_t sdo_node() const {
    const std::uint8_t raw = od_.get_u8(node_object(), 0).value_or(0);
    return kind_ == Kind::ifm ? static_cast<std::uint8_t>(raw + 1) : raw;
  }
  void add(std::uint16_t index, std::uint8_t sub, std::uint32_t value, DataType t, canopen::Access a) {
    canopen::EntryDef d;
    d.index = index;
    d.sub = sub;
    d.type = t;
    d.access = a;
    d.value = value;
    EXPECT_FALSE(od_.insert(d));
  }
  void reset() {
    ++resets_;
    std::uint8_t next = node_;
    if (lss_enabled_) {
      lss_->activate_pending();
      next = lss_->active_node_id();
    }
    if (sdo_pending_) next = *std::exchange(sdo_pending_, std::nullopt);  // node-ID object written by SDO
    node_ = next;
    if (valid(node_)) {
      sdo_->set_node_id(node_);
      sdo_->set_enabled(true);
      (void)od_.set_u8(node_object(), 0, kind_ == Kind::ifm ? static_cast<std::uint8_t>(node_ - 1) : node_);
      (void)port_.send(canopen::make_boot_up(node_));
    } else {
      sdo_->set_enabled(false);
    }
  }

  can::VirtualBus::Port& port_;
  Kind kind_;
  bool lss_enabled_;
  bool unplugged_ = false;
  canopen::ObjectDictionary od_;
  std::unique_ptr<canopen::SdoServer> sdo_;
  std::unique_ptr<canopen::LssSlave> lss_;
  std::uint8_t node_ = 0;
  std::uint32_t lss_stores_ = 0;
  std::uint32_t lss_frames_seen_ = 0;
  std::uint32_t resets_ = 0;
  std::optional<std::uint8_t> stored_node_;
  std::optional<std::uint8_t> saved_sdo_node_;
  std::optional<std::uint8_t> sdo_pending_;
};

config::Device device(std::string name, std::uint32_t serial, std::uint8_t node, std::string model = {},
                      std::optional<std::uint32_t> vendor = {}, std::optional<std::uint32_t> product = {}) {
  config::Device d;
  d.name = std::move(name);
  d.bus = "can0";
  d.serial = serial;
  if (node != 0) d.node_id = node;
  d.model = std::move(model);
  d.vendor = vendor;
  d.product = product;
  return d;
}

// The bus, the devices, a Discovery and the fake clock.
class Rig {
 public:
  explicit Rig(config::Commissioning policy = config::Commissioning::automatic,
               config::SwapPolicy swap = config::SwapPolicy::same_model) {
    config::Bus b;
    b.name = "can0";
    b.interface = "vcan0";
    b.commissioning = policy;
    b.swap_policy = swap;
    b.discovery_period_s = 10;
    b.lss_timeout_ms = 100;
    b.sdo_timeout_ms = 500;
    for (std::uint8_t n = 50; n <= 60; ++n) b.node_pool.push_back(n);
    config_.buses.push_back(b);
  }

  Rig& with(config::Device d) {
    config_.devices.push_back(std::move(d));
    return *this;
  }
  TestDevice& add(Kind k, LssAddress id, std::uint8_t node, bool lss = true,
                  std::optional<canopen::LssSlaveFeatures> features = {}) {
    devices_.push_back(std::make_unique<TestDevice>(bus_, k, id, node, lss, features));
    return *devices_.back();
  }
  // The simulator's device model (cobridge-sim's SimDevice, built from the
  // shipped EDS file), powered on at its factory node-ID.
  sim::SimDevice& add_sim(const char* model, std::uint32_t serial, const char* eds_file) {
    auto s = std::make_unique<Sim>(bus_);
    device::EdsResult r = device::load_eds_file(device::test::shipped_devices_dir() / eds_file);
    EXPECT_TRUE(r.ok()) << eds_file;
    if (r.ok()) s->eds = *r.description;
    sim::DeviceSpec spec;
    spec.model = sim::find_model(model);
    EXPECT_NE(spec.model, nullptr) << model;
    spec.serial = serial;
    s->dev = std::make_unique<sim::SimDevice>(spec, s->eds, s->port, std::filesystem::path{});
    EXPECT_FALSE(s->dev->power_on(now_));
    sims_.push_back(std::move(s));
    return *sims_.back()->dev;
  }

  // `hold`: the state file could not be read (StateStore::hold()).
  void start(std::vector<Assignment> previous = {}, std::string hold = {}) {
    disc_ = std::make_unique<Discovery>(port_, config_, 0, std::move(previous));
    if (!hold.empty()) disc_->hold_assignments(std::move(hold));
    disc_->start(now_);
  }
  Discovery& disc() { return *disc_; }

  // Runs the fake clock for `span`, delivering every frame at once.
  void run(canopen::Duration span) {
    const TimePoint end = now_ + span;
    for (int guard = 0; guard < 5'000'000; ++guard) {
      bool moved = true;
      while (moved) {
        moved = false;
        for (auto& d : devices_) d->pump(now_);
        can::Frame f;
        for (auto& s : sims_)
          while (s->port.receive(f)) s->dev->on_frame(f, now_);
        while (port_.receive(f)) {
          disc_->on_frame(f, now_);
          moved = true;
        }
        TimePoint next = disc_->process(now_);
        for (auto& s : sims_) next = std::min(next, s->dev->process(now_));
        collect();
        if (pending()) moved = true;
        if (!moved) {
          if (next >= end) {
            now_ = end;
            return;
          }
          now_ = std::max(next, now_ + 1us);
        }
      }
    }
    ADD_FAILURE() << "rig did not settle";
  }

  [[nodiscard]] bool pending() const {
    if (port_.pending() > 0) return true;
    if (std::any_of(sims_.begin(), sims_.end(), [](const auto& s) { return s->port.pending() > 0; })) return true;
    return std::any_of(devices_.begin(), devices_.end(), [](const auto& d) { return d->pending(); });
  }

  void collect() {
    for (auto& e : disc_->take_events()) events.push_back(std::move(e));
    for (auto& t : disc_->take_timings()) timings.push_back(std::move(t));
  }

  [[nodiscard]] std::vector<DiscoveryEvent> of(DiscoveryEventKind k) const {
    std::vector<DiscoveryEvent> out;
    for (const auto& e : events)
      if (e.kind == k) out.push_back(e);
    return out;
  }
  [[nodiscard]] std::size_t frames_on(std::uint32_t id) const {
    return static_cast<std::size_t>(
        std::count_if(bus_.log().begin(), bus_.log().end(), [id](const can::Frame& f) { return f.id == id; }));
  }
  [[nodiscard]] const std::vector<can::Frame>& log() const { return bus_.log(); }
  [[nodiscard]] TimePoint now() const { return now_; }

  // Sum and count of the timings of one step.
  [[nodiscard]] std::pair<double, int> step(const std::string& name) const {
    double ms = 0;
    int n = 0;
    for (const auto& t : timings)
      if (t.step == name) {
        ms += t.milliseconds;
        ++n;
      }
    return {ms, n};
  }
  void print_timings(const char* title) const {
    std::printf("[timings] %s\n", title);
    std::map<std::string, std::pair<double, int>> by;
    for (const auto& t : timings) {
      by[t.step].first += t.milliseconds;
      by[t.step].second += 1;
    }
    for (const auto& [k, v] : by) std::printf("  %-26s n=%-3d total %9.1f ms\n", k.c_str(), v.second, v.first);
  }

  std::vector<DiscoveryEvent> events;
  std::vector<StepTiming> timings;
  config::Config config_;

 private:
  can::VirtualBus bus_;
  can::VirtualBus::Port& port_ = bus_.attach();
  std::vector<std::unique_ptr<TestDevice>> devices_;
  struct Sim {
    explicit Sim(can::VirtualBus& b) : port(b.attach()) {}
    can::VirtualBus::Port& port;
    device::DeviceDescription eds;
    std::unique_ptr<sim::SimDevice> dev;
  };
  std::vector<std::unique_ptr<Sim>> sims_;
  std::unique_ptr<Discovery> disc_;
  TimePoint now_ = TimePoint{} + 1h;
};

LssAddress rotary(std::uint32_t serial, std::uint32_t product = kRfc4800, std::uint32_t rev = 0x00010003) {
  return {kNovotechnik, product, rev, serial};
}
LssAddress multiturn(std::uint32_t serial, std::uint32_t product = kMultiturn, std::uint32_t rev = 0x00010005) {
  return {kNovotechnik, product, rev, serial};
}
LssAddress ifm(std::uint32_t serial) { return {kIfm, kIfmProduct, 0x00010000, serial}; }

// J§1.2.2 / E§3.1 (factory node-ID 127), F§5.3.1 (factory node-ID 32);
// CiA 305 switch state selective + configure node-ID + store; CiA 301 §7.2.8.3.1
// reset communication. Three models, two of each, clashing at the factory
// node-IDs; the config names each device's full identity.
TEST(DiscoveryTest, SixFactoryDevicesClashingAreMovedBySerial_CiA305_J1_5_E6) {
  Rig rig;
  rig.with(device("rot-a", 1001, 10, "RFC-4800", kNovotechnik, kRfc4800))
      .with(device("rot-b", 1002, 11, "RFC-4800", kNovotechnik, kRfc4800))
      .with(device("mt-a", 2001, 20, "MC1-2800", kNovotechnik, kMultiturn))
      .with(device("mt-b", 2002, 21, "MC1-2800", kNovotechnik, kMultiturn))
      .with(device("ifm-a", 3001, 30, "RM9", kIfm, kIfmProduct))
      .with(device("ifm-b", 3002, 31, "RM9", kIfm, kIfmProduct));
  auto& ra = rig.add(Kind::rotary, rotary(1001), 127);
  auto& rb = rig.add(Kind::rotary, rotary(1002), 127);
  auto& ma = rig.add(Kind::multiturn, multiturn(2001), 127);
  auto& mb = rig.add(Kind::multiturn, multiturn(2002), 127);
  auto& ia = rig.add(Kind::ifm, ifm(3001), 32);
  auto& ib = rig.add(Kind::ifm, ifm(3002), 32);
  rig.start();
  const TimePoint t0 = rig.now();
  int seconds = 0;
  while (seconds < 600 && !(ra.node() == 10 && rb.node() == 11 && ma.node() == 20 && mb.node() == 21 &&
                           ia.node() == 30 && ib.node() == 31)) {
    rig.run(100ms);
    ++seconds;
  }
  std::printf("[timings] all six at their node-IDs after %.1f s (fake clock)\n",
              std::chrono::duration<double>(rig.now() - t0).count());
  rig.run(20s);

  auto clashes = rig.of(DiscoveryEventKind::clash_detected);
  ASSERT_EQ(clashes.size(), 2u);
  EXPECT_EQ(clashes[0].node_id, 32);
  EXPECT_EQ(clashes[0].count, 2u);
  EXPECT_EQ(clashes[1].node_id, 127);
  EXPECT_EQ(clashes[1].count, 4u);
  EXPECT_EQ(rig.of(DiscoveryEventKind::clash_resolved).size(), 2u);

  EXPECT_EQ(ra.node(), 10);
  EXPECT_EQ(rb.node(), 11);
  EXPECT_EQ(ma.node(), 20);
  EXPECT_EQ(mb.node(), 21);
  EXPECT_EQ(ia.node(), 30);
  EXPECT_EQ(ib.node(), 31);
  for (TestDevice* d : {&ra, &rb, &ma, &mb, &ia, &ib}) {
    EXPECT_EQ(d->lss_stores(), 1u);
    EXPECT_EQ(d->stored_node(), d->node());
  }
  const auto moved = rig.of(DiscoveryEventKind::commissioned);
  ASSERT_EQ(moved.size(), 6u);
  std::map<std::string, std::pair<int, int>> by_name;
  for (const auto& e : moved) by_name[e.device] = {e.previous_node_id, e.node_id};
  EXPECT_EQ(by_name["rot-a"], std::make_pair(127, 10));
  EXPECT_EQ(by_name["ifm-b"], std::make_pair(32, 31));
  // After the boot-ups every device is identified at its target node-ID.
  std::map<std::string, bool> at_target;
  for (const auto& e : rig.of(DiscoveryEventKind::identified)) at_target[e.device] = e.at_target;
  for (const char* n : {"rot-a", "rot-b", "mt-a", "mt-b", "ifm-a", "ifm-b"}) EXPECT_TRUE(at_target[n]) << n;
  EXPECT_TRUE(rig.of(DiscoveryEventKind::problem).empty()) << rig.of(DiscoveryEventKind::problem)[0].text;
  EXPECT_FALSE(rig.disc().commissioning());
  rig.print_timings("six devices, three clashes");
  EXPECT_EQ(rig.step("switch-selective").second, 6 + 2);  // two of the four at 127 needed a second revision
}

// CiA 305 identify remote slave (Slowscan) for the rotary series, whose LSS
// (J§1 intro: DSP-305 V1.1.2) predates Fastscan. Two different rotary
// products clash at 127 and the config gives serials only (with model names,
// switch selective alone takes them apart: see the mixed clash tests).
TEST(DiscoveryTest, RotaryClashResolvedBySlowscan_J1_5_CiA305) {
  Rig rig;
  rig.with(device("rot-a", 1001, 10)).with(device("rot-b", 1002, 11));
  auto& ra = rig.add(Kind::rotary, rotary(1001, kRfc4800, 0x00010003), 127);
  auto& rb = rig.add(Kind::rotary, rotary(1002, kRsa3200, 0x00010004), 127);
  rig.start();
  rig.run(60s);
  EXPECT_EQ(ra.node(), 10);
  EXPECT_EQ(rb.node(), 11);
  EXPECT_EQ(ra.stored_node(), 10);
  EXPECT_EQ(rb.stored_node(), 11);
  // Two found, one NotFound per product range.
  EXPECT_GE(rig.step("slowscan").second, 4);
  EXPECT_EQ(rig.step("fastscan").second, 0);
  ASSERT_EQ(rig.of(DiscoveryEventKind::clash_resolved).size(), 1u);
  EXPECT_TRUE(rig.of(DiscoveryEventKind::problem).empty());
  rig.print_timings("rotary clash by Slowscan");
}

// CiA 305 Fastscan after every device was made non-configured (configure
// node-ID FFh, not stored, then reset communication): two multiturn devices
// (E, LSS V3) of different product codes (E§13 V03) clash at 127 and the config
// gives only serials; an ifm device already at its node-ID keeps it.
TEST(DiscoveryTest, ClashWithoutIdentityUsesFastscanAndKnownKeepTheirIds_CiA305_E6) {
  Rig rig;
  rig.with(device("mt-a", 2001, 20)).with(device("mt-b", 2002, 21)).with(device("ifm-a", 3001, 40));
  auto& ma = rig.add(Kind::multiturn, multiturn(2001, kMultiturn, 0x10005), 127);
  auto& mb = rig.add(Kind::multiturn, multiturn(2002, kMz1V02, 0x10003), 127);
  auto& ia = rig.add(Kind::ifm, ifm(3001), 40);
  rig.start();
  rig.run(120s);
  EXPECT_EQ(ma.node(), 20);
  EXPECT_EQ(mb.node(), 21);
  EXPECT_EQ(ia.node(), 40);
  EXPECT_EQ(ma.stored_node(), 20);
  EXPECT_EQ(mb.stored_node(), 21);
  EXPECT_EQ(ia.lss_stores(), 0u);  // kept its node-ID: no store (flash wear)
  EXPECT_EQ(rig.step("fastscan").second, 4);  // three found + the empty one
  EXPECT_EQ(rig.of(DiscoveryEventKind::clash_resolved).size(), 1u);
  EXPECT_TRUE(rig.of(DiscoveryEventKind::problem).empty()) << rig.of(DiscoveryEventKind::problem)[0].text;
  rig.print_timings("multiturn clash by Fastscan");
}

// Swap policy same-model: a new serial of a configured model at the
// factory node-ID (J§1.2.2) takes the missing device's node-ID.
TEST(DiscoveryTest, UnknownSerialReplacesMissingDeviceUnderSwapPolicy_J1_2_2) {
  Rig rig;
  rig.with(device("rot-a", 1001, 10, "RFC-4800")).with(device("mt-a", 2001, 20, "MC1-2800"));
  auto& mt = rig.add(Kind::multiturn, multiturn(2001), 20);
  auto& repl = rig.add(Kind::rotary, rotary(5555), 127);
  rig.start();
  rig.run(20s);
  EXPECT_EQ(repl.node(), 10);
  EXPECT_EQ(mt.node(), 20);
  const auto moved = rig.of(DiscoveryEventKind::commissioned);
  ASSERT_EQ(moved.size(), 1u);
  EXPECT_EQ(moved[0].device, "rot-a");
  EXPECT_EQ(moved[0].replaces, "rot-a");
  EXPECT_EQ(moved[0].identity.serial, 5555u);
}

// Swap policy off: the unknown device is reported and left alone.
TEST(DiscoveryTest, UnknownSerialLeftAloneWithSwapOff_J1_2_2) {
  Rig rig(config::Commissioning::automatic, config::SwapPolicy::off);
  rig.with(device("rot-a", 1001, 10, "RFC-4800"));
  auto& repl = rig.add(Kind::rotary, rotary(5555), 127);
  rig.start();
  rig.run(20s);
  EXPECT_EQ(repl.node(), 127);
  EXPECT_EQ(rig.frames_on(canopen::cob::kLssMasterToSlave) > 0, true);  // only the non-configured check
  EXPECT_EQ(repl.lss_stores(), 0u);
  const auto problems = rig.of(DiscoveryEventKind::problem);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].text.find("unknown device"), std::string::npos);
}

// CiA 305 V3 Fastscan of a non-configured (FFh) device; E§6 claims DS-305 V3.0.0.
TEST(DiscoveryTest, NonConfiguredDeviceFoundByFastscan_CiA305_E6) {
  Rig rig;
  rig.with(device("mt-a", 2001, 20));
  auto& mt = rig.add(Kind::multiturn, multiturn(2001), canopen::cob::kNodeIdUnconfigured);
  rig.start();
  rig.run(30s);
  EXPECT_EQ(mt.node(), 20);
  EXPECT_EQ(mt.stored_node(), 20);
  const auto moved = rig.of(DiscoveryEventKind::commissioned);
  ASSERT_EQ(moved.size(), 1u);
  EXPECT_EQ(moved[0].previous_node_id, canopen::cob::kNodeIdUnconfigured);
  EXPECT_EQ(moved[0].node_id, 20);
  EXPECT_EQ(rig.step("fastscan").second, 2);
  rig.print_timings("non-configured device");
}

// Nobody left behind (CiA 305 §8.3.1 configure node-ID): the first
// configure node-ID of a non-configured device gets no answer; the device is
// searched again after 1 s (not at the next discovery period, 10 s here) and
// configured, and the failed try is reported as a `retry` event (the bus
// manager's status: commission_failures, next_retry, last_error).
TEST(DiscoveryTest, UnansweredConfigureNodeIdIsTriedAgainAfterOneSecond_CiA305_8_3_1) {
  Rig rig;
  rig.with(device("mt-a", 2001, 20));
  auto& mt = rig.add(Kind::multiturn, multiturn(2001), canopen::cob::kNodeIdUnconfigured);
  mt.ignore_configure_node_id = 1;
  rig.start();
  rig.run(3s);
  const auto retries = rig.of(DiscoveryEventKind::retry);
  ASSERT_EQ(retries.size(), 1u);
  EXPECT_EQ(retries[0].device, "mt-a");
  EXPECT_EQ(retries[0].count, 1u);
  EXPECT_EQ(retries[0].retry_in, 1s);
  EXPECT_EQ(retries[0].node_id, canopen::cob::kNodeIdUnconfigured);
  EXPECT_EQ(retries[0].target_node_id, 20);
  EXPECT_NE(retries[0].text.find("LSS configure node-ID 20 failed: no LSS answer"), std::string::npos)
      << retries[0].text;
  EXPECT_EQ(mt.node(), 20) << "configured on the second try, well before the next discovery period";
  EXPECT_EQ(mt.stored_node(), 20);
  const auto moved = rig.of(DiscoveryEventKind::commissioned);
  ASSERT_EQ(moved.size(), 1u);
  EXPECT_EQ(moved[0].node_id, 20);
  // The retry event says it (the bus manager's problem line, cleared once the
  // device is operational); no second, permanent problem event.
  for (const auto& e : rig.of(DiscoveryEventKind::problem))
    EXPECT_EQ(e.text.find("configure node-ID"), std::string::npos) << e.text;
  rig.run(60s);
  EXPECT_EQ(rig.of(DiscoveryEventKind::retry).size(), 1u) << "commissioned: no more tries";
}

// A device that never answers configure node-ID is never dropped:
// tried again and again, each wait double the last, at most 30 s.
TEST(DiscoveryTest, DeviceThatKeepsRefusingIsTriedWithBoundedBackoff_CiA305_8_3_1) {
  Rig rig;
  rig.with(device("mt-a", 2001, 20));
  auto& mt = rig.add(Kind::multiturn, multiturn(2001), canopen::cob::kNodeIdUnconfigured);
  mt.ignore_configure_node_id = 1000;
  rig.start();
  rig.run(180s);
  const auto retries = rig.of(DiscoveryEventKind::retry);
  ASSERT_GE(retries.size(), 7u);
  for (std::size_t i = 0; i < retries.size(); ++i) {
    EXPECT_EQ(retries[i].count, i + 1);
    EXPECT_LE(retries[i].retry_in, 30s);
  }
  EXPECT_EQ(retries.back().retry_in, 30s);
  EXPECT_EQ(mt.node(), canopen::cob::kNodeIdUnconfigured);
  mt.ignore_configure_node_id = 0;  // it answers again
  rig.run(40s);
  EXPECT_EQ(mt.node(), 20);
}

// Policy manual: nothing is commissioned until request_commission().
TEST(DiscoveryTest, ManualPolicyWaitsForRequestCommission_J1_5) {
  Rig rig(config::Commissioning::manual);
  rig.with(device("rot-a", 1001, 10, "RFC-4800"));
  auto& ra = rig.add(Kind::rotary, rotary(1001), 127);
  rig.start();
  rig.run(30s);
  EXPECT_EQ(ra.node(), 127);
  EXPECT_EQ(rig.frames_on(canopen::cob::kLssMasterToSlave), 0u);
  EXPECT_EQ(rig.frames_on(canopen::cob::kNmt), 0u);
  EXPECT_TRUE(rig.disc().commission_pending());
  const auto ids = rig.of(DiscoveryEventKind::identified);
  ASSERT_FALSE(ids.empty());
  EXPECT_FALSE(ids[0].at_target);
  EXPECT_EQ(ids[0].target_node_id, 10);
  rig.disc().request_commission();
  rig.run(10s);
  EXPECT_EQ(ra.node(), 10);
  EXPECT_FALSE(rig.disc().commission_pending());
}

// Policy off: only listening and identity reads (SDO upload of 0x1018, CiA 301
// §7.2.4.3.6); no LSS, no NMT, no SDO download, whatever is found.
TEST(DiscoveryTest, PolicyOffOnlyReadsIdentities_CiA301_7_2_4) {
  Rig rig(config::Commissioning::off);
  rig.with(device("rot-a", 1001, 10, "RFC-4800"));
  rig.add(Kind::rotary, rotary(1001), 127);
  rig.add(Kind::rotary, rotary(1002), 127);
  rig.add(Kind::multiturn, multiturn(2001), canopen::cob::kNodeIdUnconfigured);
  rig.start();
  rig.run(60s);
  rig.disc().request_commission();  // ignored under off
  rig.run(10s);
  std::size_t probes = 0;
  for (const auto& f : rig.log()) {
    if (f.id >= 0x601 && f.id <= 0x67F) {
      EXPECT_EQ(f.data[0], 0x40);  // upload request only
      EXPECT_EQ(f.data[1], 0x18);
      EXPECT_EQ(f.data[2], 0x10);
      ++probes;
    }
    EXPECT_NE(f.id, canopen::cob::kLssMasterToSlave);
    EXPECT_NE(f.id, canopen::cob::kNmt);
  }
  EXPECT_GT(probes, 127u);
  EXPECT_EQ(rig.of(DiscoveryEventKind::clash_detected).size(), 1u);
  EXPECT_FALSE(rig.disc().commission_pending());
}

// With discovery off the component sends nothing at all.
TEST(DiscoveryTest, DiscoveryOffSendsNothing) {
  Rig rig(config::Commissioning::off);
  rig.config_.buses[0].discovery = false;
  rig.add(Kind::rotary, rotary(1001), 127).power_on();
  rig.start();
  rig.run(30s);
  std::size_t mine = 0;
  for (const auto& f : rig.log()) mine += (f.id >= 0x600 && f.id <= 0x67F) || f.id == 0x7E5 || f.id == 0 ? 1u : 0u;
  EXPECT_EQ(mine, 0u);
}

// Wrong model for a configured serial (J§1.2.1 product codes vs E§4.1):
// reported, not configured, not moved.
TEST(DiscoveryTest, WrongModelReportedAndNotConfigured_J1_2_1_E4_1) {
  Rig rig;
  rig.with(device("mt-a", 1001, 10, "MC1-2800"));
  auto& ra = rig.add(Kind::rotary, rotary(1001), 127);
  rig.start();
  rig.run(20s);
  EXPECT_EQ(ra.node(), 127);
  EXPECT_EQ(ra.lss_stores(), 0u);
  const auto problems = rig.of(DiscoveryEventKind::problem);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].text.find("wrong model"), std::string::npos);
  const auto ids = rig.of(DiscoveryEventKind::identified);
  ASSERT_EQ(ids.size(), 1u);
  EXPECT_EQ(ids[0].target_node_id, 0);
  EXPECT_FALSE(ids[0].at_target);
}

// F§7.4 (0x3000 = node-ID - 1), F§6.3.3 (0x1010/1 'save'), CiA 301 reset node:
// an ifm device whose LSS does not answer is moved by SDO.
TEST(DiscoveryTest, IfmWithoutLssAnswerFallsBackToSdo_F7_4_F6_3_3) {
  Rig rig;
  rig.with(device("ifm-a", 3001, 30, "RM9"));
  auto& ia = rig.add(Kind::ifm, ifm(3001), 32, /*lss=*/false);
  rig.start();
  rig.run(20s);
  EXPECT_EQ(ia.node(), 30);
  EXPECT_EQ(ia.saved_sdo_node(), 30);
  bool wrote_3000 = false;
  for (const auto& f : rig.log())
    if (f.id == 0x600u + 32 && f.data[0] == 0x2F && f.data[1] == 0x00 && f.data[2] == 0x30) {
      EXPECT_EQ(f.data[4], 29);  // "always add 1": 29 + 1 = 30
      wrote_3000 = true;
    }
  EXPECT_TRUE(wrote_3000);
  ASSERT_EQ(rig.of(DiscoveryEventKind::commissioned).size(), 1u);
  rig.print_timings("ifm SDO fallback");
}

// A device already at its configured node-ID is identified at target and the
// bus sees no LSS switch / NMT at all (CiA 301 §7.2.8.3.3 boot-up re-identifies).
TEST(DiscoveryTest, DeviceAtTargetIsOnlyIdentified_CiA301_7_2_8_3_3) {
  Rig rig;
  rig.with(device("rot-a", 1001, 10, "RFC-4800"));
  auto& ra = rig.add(Kind::rotary, rotary(1001), 10);
  rig.start();
  rig.run(5s);
  ASSERT_EQ(rig.of(DiscoveryEventKind::identified).size(), 1u);
  EXPECT_TRUE(rig.of(DiscoveryEventKind::identified)[0].at_target);
  EXPECT_EQ(rig.frames_on(canopen::cob::kNmt), 0u);
  // A reboot (boot-up) is followed by a new identification, flagged boot_up.
  ra.power_on();
  rig.run(2s);
  const auto ids = rig.of(DiscoveryEventKind::identified);
  ASSERT_EQ(ids.size(), 2u);
  EXPECT_TRUE(ids[1].boot_up);
  EXPECT_TRUE(ids[1].at_target);
}

// A state file that could not be read holds every
// assignment (StateStore::hold): under policy automatic nothing is moved or
// given a node-ID (no LSS at all, no NMT, no SDO download), also not after
// `cobridge commission`; a device found at the node-ID its configuration
// gives is identified at its target all the same (it keeps working), the
// others are identified where they are and left there.
TEST(DiscoveryTest, AHeldStateFileAssignsNoNodeIdButDevicesAtTheirOwnKeepWorking) {
  Rig rig;
  rig.config_.buses[0].unknown_devices = config::UnknownDevices::assign;
  rig.with(device("rot-a", 1001, 10, "RFC-4800")).with(device("rot-b", 1002, 11, "RFC-4800"));
  auto& ra = rig.add(Kind::rotary, rotary(1001), 127);  // factory node-ID: would be moved to 10
  auto& rb = rig.add(Kind::rotary, rotary(1002), 11);   // at its own
  auto& mt = rig.add(Kind::multiturn, multiturn(2001), canopen::cob::kNodeIdUnconfigured);  // would get 50
  rig.start({}, "state file could not be read");
  rig.run(60s);
  rig.disc().request_commission();
  rig.run(10s);
  EXPECT_EQ(ra.node(), 127);
  EXPECT_EQ(rb.node(), 11);
  EXPECT_EQ(mt.node(), canopen::cob::kNodeIdUnconfigured);
  EXPECT_EQ(rig.frames_on(canopen::cob::kLssMasterToSlave), 0u);
  EXPECT_EQ(rig.frames_on(canopen::cob::kNmt), 0u);
  for (const auto& f : rig.log()) {
    if (f.id >= 0x601 && f.id <= 0x67F) {
      EXPECT_EQ(f.data[0], 0x40) << "an SDO download to node " << (f.id - 0x600);
    }
  }
  EXPECT_TRUE(rig.of(DiscoveryEventKind::commissioned).empty());
  bool b_at_target = false;
  for (const auto& e : rig.of(DiscoveryEventKind::identified)) {
    if (e.device == "rot-b") b_at_target = e.at_target && e.node_id == 11;
    if (e.device == "rot-a") {
      EXPECT_FALSE(e.at_target);
    }
  }
  EXPECT_TRUE(b_at_target);
  // Released: the bus's policy again (the bus manager starts a new Discovery
  // on the memory the operator gave back; this one moves what it queues now).
  rig.disc().hold_assignments({});
  rig.disc().request_commission();
  rig.run(30s);
  EXPECT_EQ(mt.node(), 50);
}

// Previous assignment (state file) wins for a configured device without node_id;
// otherwise the pool.
TEST(DiscoveryTest, PreviousAssignmentThenPool) {
  Rig rig;
  rig.with(device("rot-a", 1001, 0, "RFC-4800")).with(device("rot-b", 1002, 0, "RFC-4800"));
  auto& ra = rig.add(Kind::rotary, rotary(1001), 127);
  auto& rb = rig.add(Kind::rotary, rotary(1002), 127);
  Assignment a;
  a.bus = "can0";
  a.serial = 1002;
  a.vendor = kNovotechnik;
  a.product = kRfc4800;
  a.node_id = 77;
  rig.start({a});
  rig.run(30s);
  EXPECT_EQ(rb.node(), 77);
  EXPECT_EQ(ra.node(), 50);  // first of the pool
}

// Conflicting boot-ups (two from one node-ID inside the window) with the
// probe: CiA 301 §7.2.8.3.3.
// Here the second device's SDO answers are lost, so only the boot-ups tell.
TEST(DiscoveryTest, ConflictingBootupsDetectAClash_CiA301_7_2_8_3_3) {
  Rig rig(config::Commissioning::off);
  auto& a = rig.add(Kind::rotary, rotary(1001), 127);
  auto& b = rig.add(Kind::rotary, rotary(1002), 127);
  b.answer_sdo = false;
  rig.start();
  rig.run(2s);
  EXPECT_TRUE(rig.of(DiscoveryEventKind::clash_detected).empty());
  ASSERT_EQ(rig.of(DiscoveryEventKind::identified).size(), 1u);
  // Both power up again: two boot-ups from 127 within the window.
  a.power_on();
  b.power_on();
  rig.run(2s);
  const auto clashes = rig.of(DiscoveryEventKind::clash_detected);
  ASSERT_EQ(clashes.size(), 1u);
  EXPECT_EQ(clashes[0].node_id, 127);
  EXPECT_EQ(clashes[0].count, 2u);
}

// A single reboot is no clash: one boot-up, then the same identity again.
TEST(DiscoveryTest, SingleRebootIsNoClash_CiA301_7_2_8_3_3) {
  Rig rig(config::Commissioning::off);
  auto& a = rig.add(Kind::rotary, rotary(1001), 127);
  rig.start();
  rig.run(2s);
  a.power_on();
  rig.run(2s);
  EXPECT_TRUE(rig.of(DiscoveryEventKind::clash_detected).empty());
  EXPECT_EQ(rig.of(DiscoveryEventKind::identified).size(), 2u);
}

// ---- swap policy same-model (docs/configuration.md `swap_policy`) ----

// A state store in a fresh temporary directory, as the bus manager keeps it.
class TempStore {
 public:
  explicit TempStore(const std::string& name)
      : dir_(std::filesystem::path(testing::TempDir()) / ("cobridge-" + name)), store_((clean(dir_), dir_)) {}
  ~TempStore() {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  StateStore& operator*() { return store_; }
  StateStore* operator->() { return &store_; }

 private:
  static void clean(const std::filesystem::path& d) {
    std::error_code ec;
    std::filesystem::remove_all(d, ec);
  }
  std::filesystem::path dir_;
  StateStore store_;
};

Assignment assignment(std::uint32_t serial, std::uint8_t node, std::string fingerprint) {
  Assignment a;
  a.bus = "can0";
  a.serial = serial;
  a.vendor = kNovotechnik;
  a.product = kMultiturn;
  a.revision = 0x00010005;
  a.node_id = node;
  a.fingerprint = std::move(fingerprint);
  return a;
}

// Stores what the events since `from` mean for the state file, as the bus
// manager does; returns the index to continue from.
std::size_t record(StateStore& store, const Rig& rig, std::size_t from) {
  for (std::size_t i = from; i < rig.events.size(); ++i) EXPECT_FALSE(record_assignment(store, "can0", rig.events[i]));
  return rig.events.size();
}

bool any_problem_with(const Rig& rig, const std::string& words) {
  for (const auto& e : rig.of(DiscoveryEventKind::problem))
    if (e.text.find(words) != std::string::npos) return true;
  return false;
}

// The order seen on a real bus: mt-b (serial 2002) was
// at node 21 (state file), is taken off, and a new MC1-2800 (serial 2099)
// boots at the factory node-ID 127 (E§3.1) before the bus manager has noticed
// the loss (its heartbeat consumer has not timed out yet): mt-b keeps its
// place. Once the bus manager reports node 21 unsupervised, discovery probes
// it (CiA 301 SDO upload of 0x1018: no answer), and the new serial is moved
// to node 21 by LSS (CiA 305 switch selective, configure node-ID, store) as
// mt-b; the state file then holds 2099 at 21 without a fingerprint (mt-b's
// settings are written in full) and no line for 2002.
TEST(DiscoveryTest, ReplacementAtFactoryNodeTakesAbsentDevicesPlace_E3_1_CiA305) {
  TempStore store("swap-basic");
  ASSERT_FALSE(store->put(assignment(2001, 20, "fp-a")));
  ASSERT_FALSE(store->put(assignment(2002, 21, "fp-b")));
  Rig rig;
  rig.with(device("mt-a", 2001, 20, "MC1-2800")).with(device("mt-b", 2002, 0, "MC1-2800"));
  auto& ma = rig.add(Kind::multiturn, multiturn(2001), 20);
  auto& mb = rig.add(Kind::multiturn, multiturn(2002), 21);
  rig.start(store->on_bus("can0"));
  rig.run(5s);
  std::size_t done = record(*store, rig, 0);
  std::map<std::string, DiscoveryEvent> first;
  for (const auto& e : rig.of(DiscoveryEventKind::identified)) first[e.device] = e;
  ASSERT_EQ(first.size(), 2u);
  EXPECT_TRUE(first["mt-a"].at_target);
  EXPECT_TRUE(first["mt-b"].at_target);
  EXPECT_EQ(first["mt-b"].node_id, 21);  // from the state file: mt-b has no node_id in the config
  // The bus manager configures and supervises both.
  rig.disc().set_supervised(20, true);
  rig.disc().set_supervised(21, true);

  mb.unplug();
  auto& repl = rig.add(Kind::multiturn, multiturn(2099), 127);
  repl.power_on();
  rig.run(3s);
  // Node 21 is still supervised (heartbeat not timed out): nothing is taken.
  EXPECT_EQ(repl.node(), 127);
  EXPECT_EQ(repl.lss_stores(), 0u);
  EXPECT_TRUE(rig.of(DiscoveryEventKind::commissioned).empty());

  // Heartbeat lost: the bus manager marks mt-b offline.
  rig.disc().set_supervised(21, false);
  rig.run(10s);
  done = record(*store, rig, done);
  EXPECT_EQ(repl.node(), 21);
  EXPECT_EQ(repl.stored_node(), 21);
  const auto moved = rig.of(DiscoveryEventKind::commissioned);
  ASSERT_EQ(moved.size(), 1u);
  EXPECT_EQ(moved[0].device, "mt-b");
  EXPECT_EQ(moved[0].replaces, "mt-b");
  EXPECT_EQ(moved[0].identity.serial, 2099u);
  EXPECT_EQ(moved[0].replaced.serial, 2002u);
  EXPECT_EQ(moved[0].previous_node_id, 127);
  EXPECT_EQ(moved[0].node_id, 21);
  // After its boot-up at 21 it is identified there as mt-b, at its target:
  // the bus manager configures it with mt-b's settings.
  const auto ids = rig.of(DiscoveryEventKind::identified);
  ASSERT_FALSE(ids.empty());
  EXPECT_EQ(ids.back().node_id, 21);
  EXPECT_EQ(ids.back().identity.serial, 2099u);
  EXPECT_EQ(ids.back().device, "mt-b");
  EXPECT_TRUE(ids.back().at_target);
  EXPECT_FALSE(any_problem_with(rig, "held by another device"));
  // The others are untouched.
  EXPECT_EQ(ma.node(), 20);
  EXPECT_EQ(ma.lss_stores(), 0u);
  // The state file: the replacement replaces the old line.
  EXPECT_FALSE(store->find("can0", kNovotechnik, kMultiturn, 2002).has_value());
  const auto now21 = store->find("can0", kNovotechnik, kMultiturn, 2099);
  ASSERT_TRUE(now21.has_value());
  EXPECT_EQ(now21->node_id, 21);
  EXPECT_EQ(now21->fingerprint, "");
  const auto a = store->find("can0", kNovotechnik, kMultiturn, 2001);
  ASSERT_TRUE(a.has_value());
  EXPECT_EQ(a->node_id, 20);
  EXPECT_EQ(a->fingerprint, "fp-a");
  // A reload from the new state file (SIGHUP, or a restart) keeps 2099 at 21.
  rig.disc().reload(rig.config_, 0, store->on_bus("can0"));
  repl.power_on();
  rig.run(2s);
  EXPECT_EQ(rig.of(DiscoveryEventKind::identified).back().device, "mt-b");
  EXPECT_TRUE(rig.of(DiscoveryEventKind::identified).back().at_target);
}

// The other order: the loss is reported (node 21 unsupervised) while the
// replacement's probe is running, before node 21 was probed. The decision
// waits for that probe (CiA 301 SDO upload of 0x1018 to node 21) instead of
// reporting an unknown device, then the swap goes ahead (E§3.1, CiA 305).
TEST(DiscoveryTest, SwapDecisionWaitsForProbeOfUnsupervisedNode_E3_1_CiA305) {
  Rig rig;
  rig.with(device("mt-a", 2001, 20, "MC1-2800")).with(device("mt-b", 2002, 21, "MC1-2800"));
  rig.add(Kind::multiturn, multiturn(2001), 20);
  auto& mb = rig.add(Kind::multiturn, multiturn(2002), 21);
  rig.start();
  rig.run(5s);
  rig.disc().set_supervised(20, true);
  rig.disc().set_supervised(21, true);
  mb.unplug();
  auto& repl = rig.add(Kind::multiturn, multiturn(2099), 127);
  repl.power_on();
  rig.run(1ms);  // the boot-up probe of 127 is under way
  rig.disc().set_supervised(21, false);
  rig.run(10s);
  EXPECT_EQ(repl.node(), 21);
  EXPECT_FALSE(any_problem_with(rig, "unknown device"));
  const auto moved = rig.of(DiscoveryEventKind::commissioned);
  ASSERT_EQ(moved.size(), 1u);
  EXPECT_EQ(moved[0].replaces, "mt-b");
}

// Two configured MC1-2800 missing: which one a new serial replaces would be a
// guess, so it is reported and left at its factory node-ID (E§3.1).
TEST(DiscoveryTest, SwapWithTwoMissingOfTheModelIsReportedNotGuessed_E3_1) {
  Rig rig;
  rig.with(device("mt-a", 2001, 20, "MC1-2800")).with(device("mt-b", 2002, 21, "MC1-2800"));
  auto& repl = rig.add(Kind::multiturn, multiturn(2099), 127);
  rig.start();
  rig.run(20s);
  EXPECT_EQ(repl.node(), 127);
  EXPECT_EQ(repl.lss_stores(), 0u);
  EXPECT_TRUE(any_problem_with(rig, "could replace any of the missing devices mt-a, mt-b"));
  EXPECT_TRUE(rig.of(DiscoveryEventKind::commissioned).empty());
}

// A known device is never overwritten: after serial 2099 took mt-b's place,
// the old mt-b (serial 2002) comes back at the factory node-ID and is left
// alone while 2099 is present (E§3.1).
TEST(DiscoveryTest, ReplacedDeviceComingBackIsLeftAlone_E3_1) {
  Rig rig;
  rig.with(device("mt-b", 2002, 21, "MC1-2800"));
  auto& repl = rig.add(Kind::multiturn, multiturn(2099), 127);
  rig.start();
  rig.run(10s);
  ASSERT_EQ(repl.node(), 21);
  rig.disc().set_supervised(21, true);
  auto& old = rig.add(Kind::multiturn, multiturn(2002), 127);
  old.power_on();
  rig.run(10s);
  EXPECT_EQ(old.node(), 127);
  EXPECT_EQ(repl.node(), 21);
  EXPECT_TRUE(any_problem_with(rig, "has taken its place"));
  EXPECT_EQ(rig.of(DiscoveryEventKind::commissioned).size(), 1u);
}

// ---- mixed clash (two rotary + one multiturn at one node-ID) ----

// The bus settings of the end-to-end run (scripts/main-job-in-vcan): short LSS
// and SDO timeouts, as on a quiet 250 kbit/s bus.
void fast_timeouts(Rig& rig) {
  rig.config_.buses[0].lss_timeout_ms = 30;
  rig.config_.buses[0].sdo_timeout_ms = 200;
}

// Who answers the probe at `node` now, as far as discovery knows.
std::size_t identities_at(Discovery& d, std::uint8_t node) {
  for (const auto& v : d.nodes())
    if (v.node_id == node) return v.identities.size();
  return 0;
}

// J§1.2.2 / E§3.1: every Novotechnik ships at node-ID 127. Two RFC-4800
// (J, DSP-305 V1.1.2: switch selective + identify remote slave, no Fastscan)
// and one MC1-2800 (E§6, CiA 305 V3) clash there; the config gives serial +
// model only, so vendor/product come from the model and the revision from
// the probe answers (CiA 301 §7.5.2.24 0x1018). All three must end at their
// configured node-IDs (CiA 305 switch state selective, configure node-ID,
// store configuration), and the clash counts as resolved only once a probe of
// 127 (CiA 301 SDO upload of 0x1018) finds nobody left there.
TEST(DiscoveryTest, MixedClashTwoRotaryOneMultiturnAllMoved_J1_5_E6_CiA305) {
  Rig rig;
  fast_timeouts(rig);
  rig.with(device("turntable", 1001, 10, "RFC-4800"))
      .with(device("swing-arm", 1002, 11, "RFC-4800"))
      .with(device("hoist", 2001, 20, "MC1-2800"));
  auto& ra = rig.add(Kind::rotary, rotary(1001), 127);
  auto& rb = rig.add(Kind::rotary, rotary(1002), 127);
  auto& mt = rig.add(Kind::multiturn, multiturn(2001), 127);
  rig.start();
  const TimePoint t0 = rig.now();
  while (rig.now() - t0 < 60s && !(ra.node() == 10 && rb.node() == 11 && mt.node() == 20)) rig.run(100ms);
  std::printf("[timings] mixed clash: all three at their node-IDs after %.2f s (fake clock)\n",
              std::chrono::duration<double>(rig.now() - t0).count());
  rig.run(30s);  // periodic probes included: nothing may move them again
  EXPECT_EQ(ra.node(), 10);
  EXPECT_EQ(rb.node(), 11);
  EXPECT_EQ(mt.node(), 20);
  EXPECT_EQ(ra.stored_node(), 10);
  EXPECT_EQ(rb.stored_node(), 11);
  EXPECT_EQ(mt.stored_node(), 20);
  EXPECT_EQ(identities_at(rig.disc(), 127), 0u);
  const auto clashes = rig.of(DiscoveryEventKind::clash_detected);
  ASSERT_EQ(clashes.size(), 1u);
  EXPECT_EQ(clashes[0].node_id, 127);
  EXPECT_EQ(clashes[0].count, 3u);
  const auto resolved = rig.of(DiscoveryEventKind::clash_resolved);
  ASSERT_EQ(resolved.size(), 1u);
  EXPECT_EQ(resolved[0].node_id, 127);
  std::map<std::string, std::pair<int, int>> by_name;
  for (const auto& e : rig.of(DiscoveryEventKind::commissioned)) by_name[e.device] = {e.previous_node_id, e.node_id};
  EXPECT_EQ(by_name["turntable"], std::make_pair(127, 10));
  EXPECT_EQ(by_name["swing-arm"], std::make_pair(127, 11));
  EXPECT_EQ(by_name["hoist"], std::make_pair(127, 20));
  EXPECT_FALSE(any_problem_with(rig, "could not be resolved"));
  EXPECT_TRUE(rig.of(DiscoveryEventKind::problem).empty()) << rig.of(DiscoveryEventKind::problem)[0].text;
  EXPECT_FALSE(rig.disc().commissioning());
  rig.print_timings("mixed clash, two rotary + one multiturn");
}

// The whole bus of the end-to-end run: the mixed clash at 127 (J§1.2.2,
// E§3.1) plus an ifm RM9000 alone at its factory node-ID 32 (F§5.3.1). Each
// device ends at its configured node-ID (CiA 305 / F§7.4).
TEST(DiscoveryTest, MixedClashAndIfmAllReachTheirNodeIds_J1_2_2_E3_1_F5_3_1) {
  Rig rig;
  fast_timeouts(rig);
  rig.with(device("turntable", 1001, 10, "RFC-4800"))
      .with(device("swing-arm", 1002, 11, "RFC-4800"))
      .with(device("hoist", 2001, 20, "MC1-2800"))
      .with(device("conveyor", 3001, 30, "RM9000"));
  auto& ra = rig.add(Kind::rotary, rotary(1001), 127);
  auto& rb = rig.add(Kind::rotary, rotary(1002), 127);
  auto& mt = rig.add(Kind::multiturn, multiturn(2001), 127);
  auto& im = rig.add(Kind::ifm, ifm(3001), 32);
  rig.start();
  const TimePoint t0 = rig.now();
  while (rig.now() - t0 < 60s && !(ra.node() == 10 && rb.node() == 11 && mt.node() == 20 && im.node() == 30))
    rig.run(100ms);
  std::printf("[timings] mixed clash + ifm: all four at their node-IDs after %.2f s (fake clock)\n",
              std::chrono::duration<double>(rig.now() - t0).count());
  rig.run(30s);
  EXPECT_EQ(ra.node(), 10);
  EXPECT_EQ(rb.node(), 11);
  EXPECT_EQ(mt.node(), 20);
  EXPECT_EQ(im.node(), 30);
  EXPECT_EQ(identities_at(rig.disc(), 127), 0u);
  EXPECT_EQ(identities_at(rig.disc(), 32), 0u);
  std::map<std::string, bool> at_target;
  for (const auto& e : rig.of(DiscoveryEventKind::identified)) at_target[e.device] = e.at_target;
  for (const char* n : {"turntable", "swing-arm", "hoist", "conveyor"}) EXPECT_TRUE(at_target[n]) << n;
  EXPECT_EQ(rig.of(DiscoveryEventKind::clash_resolved).size(), 1u);
  EXPECT_TRUE(rig.of(DiscoveryEventKind::problem).empty()) << rig.of(DiscoveryEventKind::problem)[0].text;
  rig.print_timings("mixed clash + ifm");
}

// J§1.5 documents switch selective, configure node-ID and store only (no
// identify remote slave): Slowscan cannot find such a rotary device, and
// Fastscan (CiA 305 V2.2+) neither. The mixed clash is still taken apart by
// switch selective alone (vendor/product from the model, revision from the
// probe) and nobody ends non-configured (CiA 305 identify non-configured).
TEST(DiscoveryTest, MixedClashWithRotaryWithoutIdentifyUsesSwitchSelective_J1_5_CiA305) {
  Rig rig;
  fast_timeouts(rig);
  rig.with(device("turntable", 1001, 10, "RFC-4800"))
      .with(device("swing-arm", 1002, 11, "RFC-4800"))
      .with(device("hoist", 2001, 20, "MC1-2800"));
  canopen::LssSlaveFeatures j_only = canopen::LssSlaveFeatures::rotary_j();
  j_only.identify = false;
  auto& ra = rig.add(Kind::rotary, rotary(1001), 127, true, j_only);
  auto& rb = rig.add(Kind::rotary, rotary(1002), 127, true, j_only);
  auto& mt = rig.add(Kind::multiturn, multiturn(2001), 127);
  rig.start();
  rig.run(40s);
  EXPECT_EQ(ra.node(), 10);
  EXPECT_EQ(rb.node(), 11);
  EXPECT_EQ(mt.node(), 20);
  EXPECT_EQ(ra.stored_node(), 10);
  EXPECT_EQ(rb.stored_node(), 11);
  EXPECT_EQ(mt.stored_node(), 20);
  EXPECT_EQ(identities_at(rig.disc(), 127), 0u);
  EXPECT_EQ(rig.step("fastscan").second, 0);  // nobody was made non-configured
  EXPECT_EQ(rig.of(DiscoveryEventKind::clash_resolved).size(), 1u);
  for (const auto& e : rig.of(DiscoveryEventKind::problem)) ADD_FAILURE() << e.text;
  rig.print_timings("mixed clash, rotary without identify");
}

// A resolution that leaves several devices at the clash node is not a
// resolution: the probe after it (CiA 301 SDO upload of 0x1018) still sees a
// clash, so no clash_resolved goes out and the next strategy runs. Here the
// LSS requests of the first run do not reach two MC1-2800 (E§6); the second
// run (Slowscan + Fastscan after configure node-ID FFh, CiA 305) moves them.
TEST(DiscoveryTest, ClashStillThereAfterResolutionRunsNextStrategy_CiA305_E6) {
  Rig rig;
  fast_timeouts(rig);
  rig.with(device("mt-a", 2001, 20, "MC1-2800")).with(device("mt-b", 2002, 21, "MC1-2800"));
  auto& ma = rig.add(Kind::multiturn, multiturn(2001), 127);
  auto& mb = rig.add(Kind::multiturn, multiturn(2002), 127);
  ma.answer_lss = false;
  mb.answer_lss = false;
  rig.start();
  const TimePoint t0 = rig.now();
  while (rig.now() - t0 < 30s && rig.step("clash-resolution").second == 0) rig.run(10ms);
  ASSERT_EQ(rig.step("clash-resolution").second, 1);
  ma.answer_lss = true;
  mb.answer_lss = true;
  // The first run moved nobody: it must not be called resolved.
  EXPECT_EQ(ma.node(), 127);
  EXPECT_EQ(mb.node(), 127);
  EXPECT_TRUE(rig.of(DiscoveryEventKind::clash_resolved).empty());
  rig.run(60s);
  EXPECT_EQ(ma.node(), 20);
  EXPECT_EQ(mb.node(), 21);
  EXPECT_EQ(rig.step("clash-resolution").second, 2);
  ASSERT_EQ(rig.of(DiscoveryEventKind::clash_resolved).size(), 1u);
  EXPECT_EQ(identities_at(rig.disc(), 127), 0u);
  EXPECT_FALSE(any_problem_with(rig, "could not be resolved"));
}

// When every strategy has run and devices still clash, that is reported once
// and no resolution is claimed (CiA 301 §7.2.4.3.3 probe of 0x1018).
TEST(DiscoveryTest, ClashThatNoStrategyResolvesIsReportedNotResolved_CiA305) {
  Rig rig;
  fast_timeouts(rig);
  rig.with(device("mt-a", 2001, 20, "MC1-2800")).with(device("mt-b", 2002, 21, "MC1-2800"));
  auto& ma = rig.add(Kind::multiturn, multiturn(2001), 127);
  auto& mb = rig.add(Kind::multiturn, multiturn(2002), 127);
  ma.answer_lss = false;
  mb.answer_lss = false;
  rig.start();
  rig.run(120s);
  EXPECT_EQ(ma.node(), 127);
  EXPECT_EQ(mb.node(), 127);
  EXPECT_TRUE(rig.of(DiscoveryEventKind::clash_resolved).empty());
  EXPECT_TRUE(any_problem_with(rig, "the clash at node 127 could not be resolved"));
  EXPECT_EQ(rig.step("clash-resolution").second, 3);  // one run per strategy, then it stops
  EXPECT_FALSE(rig.disc().commissioning());
}

// A rotary device left non-configured (node-ID FFh, e.g. by an earlier
// interrupted run): it answers CiA 305 identify non-configured, but its LSS
// (J§1 intro: DSP-305 V1.1.2) has no Fastscan. Slowscan finds it, and it gets
// its configured node-ID (configure node-ID, store, switch global waiting).
TEST(DiscoveryTest, NonConfiguredRotaryFoundBySlowscanWhenFastscanFindsNone_J1_5_CiA305) {
  Rig rig;
  fast_timeouts(rig);
  rig.with(device("turntable", 1001, 10, "RFC-4800"));
  auto& ra = rig.add(Kind::rotary, rotary(1001), canopen::cob::kNodeIdUnconfigured);
  rig.start();
  rig.run(20s);
  EXPECT_EQ(ra.node(), 10);
  EXPECT_EQ(ra.stored_node(), 10);
  EXPECT_GE(rig.step("slowscan").second, 1);
  const auto moved = rig.of(DiscoveryEventKind::commissioned);
  ASSERT_EQ(moved.size(), 1u);
  EXPECT_EQ(moved[0].device, "turntable");
  EXPECT_EQ(moved[0].previous_node_id, canopen::cob::kNodeIdUnconfigured);
  for (const auto& e : rig.of(DiscoveryEventKind::problem)) ADD_FAILURE() << e.text;
}

// The same bus with the simulator's device models (what cobridge-sim runs in
// the end-to-end test): RFC-4800 with the J LSS (DSP-305 V1.1.2),
// MC1-2800 with CiA 305 V3 (E§6), RM9000 at 32 (F§5.3.1).
TEST(DiscoveryTest, MixedClashOnSimulatedDevicesAllReachTheirNodeIds_J1_2_2_E3_1_F5_3_1) {
  Rig rig;
  fast_timeouts(rig);
  rig.with(device("turntable", 1001, 10, "RFC-4800"))
      .with(device("swing-arm", 1002, 11, "RFC-4800"))
      .with(device("hoist", 2001, 20, "MC1-2800"))
      .with(device("conveyor", 3001, 30, "RM9000"));
  auto& ra = rig.add_sim("RFC-4800", 1001, "novotechnik-rfc4800-1ch.eds");
  auto& rb = rig.add_sim("RFC-4800", 1002, "novotechnik-rfc4800-1ch.eds");
  auto& mt = rig.add_sim("MC1-2800", 2001, "novotechnik-multiturn.eds");
  auto& im = rig.add_sim("RM9000", 3001, "ifm-rm8-rm9.eds");
  ASSERT_EQ(ra.node_id(), 127);
  ASSERT_EQ(im.node_id(), 32);
  rig.start();
  const TimePoint t0 = rig.now();
  const auto all_there = [&] {
    return ra.node_id() == 10 && rb.node_id() == 11 && mt.node_id() == 20 && im.node_id() == 30;
  };
  while (rig.now() - t0 < 60s && !all_there()) rig.run(100ms);
  std::printf("[timings] simulated mixed clash + ifm: all four at their node-IDs after %.2f s (fake clock)\n",
              std::chrono::duration<double>(rig.now() - t0).count());
  rig.run(30s);
  EXPECT_EQ(ra.node_id(), 10);
  EXPECT_EQ(rb.node_id(), 11);
  EXPECT_EQ(mt.node_id(), 20);
  EXPECT_EQ(im.node_id(), 30);
  EXPECT_EQ(identities_at(rig.disc(), 127), 0u);
  std::map<std::string, bool> at_target;
  for (const auto& e : rig.of(DiscoveryEventKind::identified)) at_target[e.device] = e.at_target;
  for (const char* n : {"turntable", "swing-arm", "hoist", "conveyor"}) EXPECT_TRUE(at_target[n]) << n;
  EXPECT_EQ(rig.of(DiscoveryEventKind::clash_resolved).size(), 1u);
  for (const auto& e : rig.of(DiscoveryEventKind::problem)) ADD_FAILURE() << e.text;
  rig.print_timings("simulated mixed clash + ifm");
}

// The event texts leave the bus name to the bus manager's log lines.
TEST(DiscoveryTest, EventTextsDoNotRepeatTheBusName) {
  Rig rig(config::Commissioning::automatic, config::SwapPolicy::off);
  rig.with(device("rot-a", 1001, 10, "RFC-4800"));
  rig.add(Kind::rotary, rotary(1001), 127);
  rig.add(Kind::rotary, rotary(5555), 32);
  rig.start();
  rig.run(20s);
  ASSERT_FALSE(rig.events.empty());
  for (const auto& e : rig.events) EXPECT_EQ(e.text.find("bus can0"), std::string::npos) << e.text;
}

}  // namespace
}  // namespace cobridge::bus
