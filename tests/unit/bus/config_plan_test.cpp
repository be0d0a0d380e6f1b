// ConfigPlan: the steps, sizes, masks and errors derived from a [[device]]
// section, the family's shipped EDS and its profile.
#include "bus/config_plan.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "device/eds.hpp"
#include "device/family_profile.hpp"
#include "unit/device/source_paths.hpp"

namespace cobridge::bus {
namespace {

using config::Signal;

struct Fixture {
  device::DeviceDescription eds;
  device::FamilyProfile profile;
};

Fixture load(const std::string& file) {
  device::EdsResult r = device::load_eds_file(device::test::shipped_devices_dir() / file);
  EXPECT_TRUE(r.ok()) << file;
  Fixture f{r.ok() ? *r.description : device::DeviceDescription{}, {}};
  auto p = device::family_profile_for(f.eds);
  EXPECT_TRUE(p) << file;
  if (p) f.profile = *p;
  return f;
}

config::Device device_named(const std::string& name) {
  config::Device d;
  d.name = name;
  return d;
}

ConfigPlan plan_ok(const config::Device& d, const Fixture& f, std::uint8_t node = 5) {
  ConfigPlanResult r = make_config_plan(d, f.eds, f.profile, node);
  for (const auto& e : r.errors) ADD_FAILURE() << e.to_string();
  EXPECT_TRUE(r.ok());
  return r.ok() ? *r.plan : ConfigPlan{};
}

const PlanStep* find_write(const ConfigPlan& p, std::uint16_t index, std::uint8_t sub) {
  for (const PlanStep& s : p.steps)
    if (s.kind == StepKind::write && s.write.index == index && s.write.sub == sub) return &s;
  return nullptr;
}

std::ptrdiff_t position_of(const ConfigPlan& p, const PlanStep* s) { return s - p.steps.data(); }

std::vector<std::string> error_texts(const ConfigPlanResult& r) {
  std::vector<std::string> out;
  for (const auto& e : r.errors) out.push_back(e.to_string());
  return out;
}

bool contains(const std::vector<std::string>& texts, const std::string& needle) {
  return std::any_of(texts.begin(), texts.end(), [&](const std::string& t) { return t == needle; });
}

// An empty [[device]] changes nothing: enter pre-operational, start; no store
// (a setting left out is not written; docs/configuration.md).
TEST(ConfigPlan, EmptySettingsOnlyNmt) {
  const Fixture f = load("novotechnik-multiturn.eds");
  const ConfigPlan p = plan_ok(device_named("lift"), f);
  ASSERT_EQ(p.steps.size(), 2u);
  EXPECT_EQ(p.steps[0].kind, StepKind::nmt);
  EXPECT_EQ(p.steps[0].nmt, canopen::NmtCommand::enter_preop);
  EXPECT_EQ(p.steps[1].nmt, canopen::NmtCommand::start);
  EXPECT_EQ(p.fingerprint.size(), 16u);
}

// Order (E§8.2, E§11): pre-operational, remap before the
// transmission type, application values, store in pre-operational, start.
TEST(ConfigPlan, E8_2_E11_StepOrderForMultiturn) {
  const Fixture f = load("novotechnik-multiturn.eds");
  config::Device d = device_named("lift");
  d.tpdo1 = config::TpdoSettings{std::vector<config::MappingEntry>{{Signal::position, 0}, {Signal::speed, 0}},
                                 254, 100, 10};
  d.heartbeat_ms = 500;
  d.direction = config::Direction::ccw;
  d.preset = 1000;
  const ConfigPlan p = plan_ok(d, f);
  ASSERT_GE(p.steps.size(), 8u);
  EXPECT_EQ(p.steps.front().nmt, canopen::NmtCommand::enter_preop);
  EXPECT_EQ(p.steps.back().kind, StepKind::nmt);
  EXPECT_EQ(p.steps.back().nmt, canopen::NmtCommand::start);
  EXPECT_EQ(p.steps[p.steps.size() - 2].kind, StepKind::store);
  EXPECT_EQ(p.steps[1].kind, StepKind::tpdo_mapping);
  EXPECT_EQ(p.steps[1].mapping, (std::vector<std::uint32_t>{0x60040020, 0x60300110}));
  EXPECT_EQ(p.steps[1].comm_index, 0x1800);
  EXPECT_EQ(p.steps[1].map_index, 0x1A00);
  const PlanStep* tt = find_write(p, 0x1800, 2);
  const PlanStep* et = find_write(p, 0x1800, 5);
  const PlanStep* it = find_write(p, 0x1800, 3);
  const PlanStep* hb = find_write(p, 0x1017, 0);
  const PlanStep* op = find_write(p, 0x6000, 0);
  const PlanStep* pr = find_write(p, 0x6003, 0);
  ASSERT_TRUE(tt && et && it && hb && op && pr);
  EXPECT_LT(position_of(p, tt), position_of(p, it));
  EXPECT_LT(position_of(p, it), position_of(p, et));
  EXPECT_LT(position_of(p, et), position_of(p, hb));
  EXPECT_LT(position_of(p, hb), position_of(p, op));
  EXPECT_LT(position_of(p, op), position_of(p, pr));
  EXPECT_EQ(tt->write.value, 254u);
  EXPECT_EQ(tt->write.size, 1);
  EXPECT_EQ(et->write.size, 2);
  EXPECT_EQ(pr->write.value, 1000u);
  EXPECT_EQ(pr->write.size, 4);
  EXPECT_TRUE(pr->write.verify);
  EXPECT_TRUE(hb->fallback.empty());  // E§3.1: heartbeat producer
  EXPECT_TRUE(p.heartbeat);
}

// 0x6000 is a read-modify-write of the bits the settings own; its size comes
// from the EDS: E§4.2 Unsigned8, J§1.3.2 UNSIGNED16. Scaling polarity E§5.3
// (0 = on) vs J§1.4.1 (1 = on); rotary moving average in bits 14..12.
TEST(ConfigPlan, OperatingParameterMaskAndPolarity_E5_3_J1_4_1) {
  config::Device d = device_named("lift");
  d.direction = config::Direction::ccw;
  d.scaling = config::Scaling{4096, std::nullopt};
  {
    const ConfigPlan p = plan_ok(d, load("novotechnik-multiturn.eds"));
    const PlanStep* op = find_write(p, 0x6000, 0);
    ASSERT_TRUE(op);
    EXPECT_EQ(op->write.size, 1);
    EXPECT_EQ(op->write.mask, 0x5u);
    EXPECT_EQ(op->write.value, 0x1u);  // scaling on = bit 2 clear
    EXPECT_EQ(op->label, "direction, scaling");
    const PlanStep* upr = find_write(p, 0x6001, 0);
    ASSERT_TRUE(upr);
    EXPECT_LT(position_of(p, op), position_of(p, upr));  // enable before 0x6001 (E§5.4)
    EXPECT_EQ(op->write.merged(0xFE), 0xFBu);           // other bits kept
  }
  d.position_filter = 3;
  {
    const ConfigPlan p = plan_ok(d, load("novotechnik-rfc4800-1ch.eds"));
    const PlanStep* op = find_write(p, 0x6000, 0);
    ASSERT_TRUE(op);
    EXPECT_EQ(op->write.size, 2);
    EXPECT_EQ(op->write.mask, 0x7005u);
    EXPECT_EQ(op->write.value, 0x3005u);
    EXPECT_FALSE(find_write(p, 0x2010, 1));
  }
}

// E§5.1 / E§5.2: multiturn filters are 0x2010/1 and /2; F has none; only E
// has a speed filter.
TEST(ConfigPlan, Filters_E5_1_E5_2) {
  config::Device d = device_named("lift");
  d.position_filter = 4;
  d.speed_filter = 5;
  const ConfigPlan p = plan_ok(d, load("novotechnik-multiturn.eds"));
  ASSERT_TRUE(find_write(p, 0x2010, 1));
  EXPECT_EQ(find_write(p, 0x2010, 1)->write.value, 4u);
  EXPECT_EQ(find_write(p, 0x2010, 2)->write.value, 5u);

  const Fixture rm = load("ifm-rm8-rm9.eds");
  const auto r = make_config_plan(d, rm.eds, rm.profile, 5);
  EXPECT_FALSE(r.ok());
  const auto texts = error_texts(r);
  EXPECT_EQ(texts.size(), 2u);
  EXPECT_NE(texts[0].find("position_filter"), std::string::npos);
  EXPECT_NE(texts[1].find("speed_filter"), std::string::npos);
}

// The example of the brief: CAM 5 on the multiturn series (E§3.4: 4 CAMs).
TEST(ConfigPlan, E3_4_CamBeyondFamilyIsAnError) {
  const Fixture f = load("novotechnik-multiturn.eds");
  config::Device d = device_named("lift");
  config::Cam cam;
  cam.index = 5;
  cam.low = 10;
  d.cams.push_back(cam);
  const auto r = make_config_plan(d, f.eds, f.profile, 5);
  ASSERT_FALSE(r.ok());
  ASSERT_EQ(r.errors.size(), 1u);
  EXPECT_EQ(r.errors[0].to_string(), "device 'lift': cam 5: the multiturn series has 4 CAMs (E§3.4)");
  EXPECT_EQ(r.errors[0].device, "lift");
  EXPECT_EQ(r.errors[0].setting, "cam 5");
}

// J§1.2.3 / J§1.3.2: CAM 6 of a 2-channel rotary is CAM 2 of channel 2; the
// enable and polarity registers are per channel and written as masks.
TEST(ConfigPlan, J1_2_3_CamsPerChannel) {
  config::Device d = device_named("arm");
  config::Cam c1;
  c1.index = 1;
  c1.low = 100;
  c1.high = 200;
  c1.hysteresis = 5;
  c1.enabled = true;
  config::Cam c2;
  c2.index = 2;
  c2.enabled = false;
  c2.polarity = config::CamPolarity::inverted;
  config::Cam c6;
  c6.index = 6;
  c6.low = -5;
  c6.enabled = true;
  d.cams = {c1, c2, c6};
  const ConfigPlan p = plan_ok(d, load("novotechnik-rfc4800-2ch.eds"));
  ASSERT_TRUE(find_write(p, 0x6310, 1));
  EXPECT_EQ(find_write(p, 0x6320, 1)->write.value, 200u);
  EXPECT_EQ(find_write(p, 0x6330, 1)->write.size, 2);  // J§1.3.2 INTEGER16
  EXPECT_EQ(find_write(p, 0x6311, 2)->write.value, 0xFFFFFFFBu);
  const PlanStep* en1 = find_write(p, 0x6301, 1);
  ASSERT_TRUE(en1);
  EXPECT_EQ(en1->write.mask, 0x3u);
  EXPECT_EQ(en1->write.value, 0x1u);
  EXPECT_EQ(find_write(p, 0x6302, 1)->write.mask, 0x2u);
  EXPECT_EQ(find_write(p, 0x6302, 1)->write.value, 0x2u);
  EXPECT_EQ(find_write(p, 0x6301, 2)->write.mask, 0x2u);
  EXPECT_FALSE(find_write(p, 0x6302, 2));
  // Limits before switches.
  EXPECT_LT(position_of(p, find_write(p, 0x6310, 1)), position_of(p, en1));

  const Fixture one = load("novotechnik-rfc4800-1ch.eds");
  const auto r = make_config_plan(d, one.eds, one.profile, 5);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.errors[0].setting, "cam 6");
  EXPECT_NE(r.errors[0].reason.find("J§1.2.3"), std::string::npos);
}

// F§7.5: ifm CAM hysteresis is u32 (size 4), 8 CAMs.
TEST(ConfigPlan, F7_5_IfmCamSizes) {
  config::Device d = device_named("wheel");
  config::Cam c8;
  c8.index = 8;
  c8.hysteresis = 7;
  c8.high = 4000000000;
  d.cams = {c8};
  const ConfigPlan p = plan_ok(d, load("ifm-rm8-rm9.eds"));
  EXPECT_EQ(find_write(p, 0x6337, 1)->write.size, 4);
  EXPECT_EQ(find_write(p, 0x6327, 1)->write.value, 4000000000u);
}

// Semantic mapping per family (J§1.7.2, E§8.2) and the errors: a signal the
// family lacks, more than 5 entries, more than 8 bytes, an unknown object.
TEST(ConfigPlan, J1_7_2_MappingErrors) {
  const Fixture f = load("novotechnik-rfc4800-1ch.eds");
  config::Device d = device_named("arm");
  d.tpdo1 = config::TpdoSettings{};
  d.tpdo1->mapping = std::vector<config::MappingEntry>{{Signal::temperature, 0}};
  auto r = make_config_plan(d, f.eds, f.profile, 5);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.errors[0].setting, "tpdo1 mapping entry 1 (temperature)");
  EXPECT_NE(r.errors[0].reason.find("E§4.3"), std::string::npos);

  d.tpdo1->mapping = std::vector<config::MappingEntry>(6, config::MappingEntry{Signal::cam, 0});
  r = make_config_plan(d, f.eds, f.profile, 5);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(error_texts(r),
                       "device 'arm': tpdo1 mapping: 6 entries, but TPDO1 of the rotary series maps at most 5 "
                       "(J§1.7.2, E§8.2)"));

  d.tpdo1->mapping = std::vector<config::MappingEntry>{
      {Signal::position, 0}, {Signal::position, 0}, {Signal::speed, 0}};
  r = make_config_plan(d, f.eds, f.profile, 5);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.errors[0].reason.find("80 bits"), std::string::npos);

  d.tpdo1->mapping = std::vector<config::MappingEntry>{{Signal::raw, 0x70000120}};
  r = make_config_plan(d, f.eds, f.profile, 5);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.errors[0].reason.find("0x7000/1 is not in the device description"), std::string::npos);

  d.tpdo1->mapping = std::vector<config::MappingEntry>{{Signal::raw, 0x60200110}};  // wrong length
  r = make_config_plan(d, f.eds, f.profile, 5);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.errors[0].reason.find("maps 16 bits"), std::string::npos);
}

// E§4.1: the multiturn default mapping names 0x6020/1, accepted as the
// position alias of 0x6004.
TEST(ConfigPlan, E4_1_MultiturnAcceptsPositionAlias) {
  config::Device d = device_named("lift");
  d.tpdo1 = config::TpdoSettings{};
  d.tpdo1->mapping = std::vector<config::MappingEntry>{{Signal::raw, 0x60200120}, {Signal::voltage, 0}};
  const ConfigPlan p = plan_ok(d, load("novotechnik-multiturn.eds"));
  ASSERT_EQ(p.steps[1].kind, StepKind::tpdo_mapping);
  EXPECT_EQ(p.steps[1].mapping, (std::vector<std::uint32_t>{0x60200120, 0x20030010}));
}

// J§1.3.1 0x1801: TPDO2 of the rotary series has no event timer and is
// synchronous only.
TEST(ConfigPlan, J1_3_1_Tpdo2SynchronousOnly) {
  const Fixture f = load("novotechnik-rfc4800-1ch.eds");
  config::Device d = device_named("arm");
  d.tpdo2 = config::TpdoSettings{std::nullopt, 254, 100, std::nullopt};
  const auto r = make_config_plan(d, f.eds, f.profile, 5);
  ASSERT_FALSE(r.ok());
  ASSERT_EQ(r.errors.size(), 2u);
  EXPECT_EQ(r.errors[0].setting, "tpdo2 transmission");
  EXPECT_NE(r.errors[0].reason.find("synchronous only"), std::string::npos);
  EXPECT_EQ(r.errors[1].setting, "tpdo2 event timer");
  EXPECT_NE(r.errors[1].reason.find("J§1.3.1"), std::string::npos);
  d.tpdo2 = config::TpdoSettings{std::nullopt, 1, std::nullopt, 20};
  const ConfigPlan p = plan_ok(d, f);
  EXPECT_EQ(find_write(p, 0x1801, 2)->write.value, 1u);
  EXPECT_EQ(find_write(p, 0x1801, 3)->write.value, 20u);
}

// F§7.4 0x3010/1: speed must be enabled before it can be mapped; F§7.5 0x6200
// is the event timer too.
TEST(ConfigPlan, F7_4_IfmSpeedEnableAndEventTimerAlias) {
  config::Device d = device_named("wheel");
  d.tpdo1 = config::TpdoSettings{std::vector<config::MappingEntry>{{Signal::position, 0}, {Signal::speed, 0}},
                                 254, 50, std::nullopt};
  const ConfigPlan p = plan_ok(d, load("ifm-rm8-rm9.eds"));
  const PlanStep* enable = find_write(p, 0x3010, 1);
  ASSERT_TRUE(enable);
  EXPECT_EQ(enable->write.value, 1u);
  EXPECT_EQ(p.steps[2].kind, StepKind::tpdo_mapping);
  EXPECT_LT(position_of(p, enable), 2);
  EXPECT_EQ(find_write(p, 0x1800, 5)->write.size, 4);  // F§7.3 u32 as printed
  ASSERT_TRUE(find_write(p, 0x6200, 0));
  EXPECT_EQ(find_write(p, 0x6200, 0)->write.value, 50u);
}

// Values outside the object's type or EDS limits: E§4.2 0x6003 is UNSIGNED32.
TEST(ConfigPlan, E4_2_ValueOutsideObjectRange) {
  const Fixture f = load("novotechnik-multiturn.eds");
  config::Device d = device_named("lift");
  d.preset = -1;
  const auto r = make_config_plan(d, f.eds, f.profile, 5);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.errors[0].to_string(),
            "device 'lift': preset: -1 is outside 0..4294967295 of object 0x6003 (UNSIGNED32)");
}

// J§1.2.2: the rotary series may lack heartbeat; the plan carries the node
// guarding fallback (guard time = heartbeat period, life time factor 3).
TEST(ConfigPlan, J1_2_2_RotaryHeartbeatHasGuardingFallback) {
  config::Device d = device_named("arm");
  d.heartbeat_ms = 200;
  const ConfigPlan p = plan_ok(d, load("novotechnik-rfc4800-1ch.eds"));
  const PlanStep* hb = find_write(p, 0x1017, 0);
  ASSERT_TRUE(hb);
  ASSERT_EQ(hb->fallback.size(), 2u);
  EXPECT_EQ(hb->fallback[0].index, 0x100C);
  EXPECT_EQ(hb->fallback[0].value, 200u);
  EXPECT_EQ(hb->fallback[1].index, 0x100D);
  EXPECT_EQ(hb->fallback[1].value, 3u);
  d.heartbeat_ms.reset();
  d.guarding = config::Guarding{100, 4};
  const ConfigPlan g = plan_ok(d, load("novotechnik-rfc4800-1ch.eds"));
  EXPECT_EQ(find_write(g, 0x100C, 0)->write.value, 100u);
  EXPECT_EQ(find_write(g, 0x100D, 0)->write.value, 4u);
  EXPECT_FALSE(g.heartbeat);
}

// E§11 table: communication parameters with /2 (not /1, which resets the TPDO
// COB-ID), application with /3; F§7.3: ifm has /1 only; policy never: no
// store step.
TEST(ConfigPlan, E11_F7_3_StoreTargets) {
  config::Device d = device_named("lift");
  d.preset = 10;
  {
    const ConfigPlan p = plan_ok(d, load("novotechnik-multiturn.eds"));
    const PlanStep& st = p.steps[p.steps.size() - 2];
    ASSERT_EQ(st.kind, StepKind::store);
    ASSERT_EQ(st.store.size(), 1u);
    EXPECT_EQ(st.store[0].sub, 3);
  }
  d.heartbeat_ms = 100;
  {
    const ConfigPlan p = plan_ok(d, load("novotechnik-multiturn.eds"));
    const PlanStep& st = p.steps[p.steps.size() - 2];
    ASSERT_EQ(st.store.size(), 2u);
    EXPECT_EQ(st.store[0].sub, 2);
    EXPECT_EQ(st.store[0].groups, bit(StoreGroup::communication));
    EXPECT_EQ(st.store[1].sub, 3);
  }
  {
    const ConfigPlan p = plan_ok(d, load("ifm-rm8-rm9.eds"));
    const PlanStep& st = p.steps[p.steps.size() - 2];
    ASSERT_EQ(st.store.size(), 1u);
    EXPECT_EQ(st.store[0].sub, 1);
    EXPECT_EQ(st.store[0].groups, bit(StoreGroup::communication) | bit(StoreGroup::application));
  }
  d.store = config::StorePolicy::never;
  {
    const ConfigPlan p = plan_ok(d, load("ifm-rm8-rm9.eds"));
    EXPECT_TRUE(std::none_of(p.steps.begin(), p.steps.end(),
                             [](const PlanStep& s) { return s.kind == StepKind::store; }));
  }
}

// F§7.4 0x3000: node-ID 10 is written as 9; 'save' to 0x1010/1; no start.
// J§1.6.1: rotary node-ID stored with /4 (RSX/RFX /1).
TEST(ConfigPlan, F7_4_J1_6_1_NodeIdPlan) {
  const Fixture rm = load("ifm-rm8-rm9.eds");
  auto r = make_node_id_plan("wheel", rm.eds, rm.profile, 32, 10, 250);
  ASSERT_TRUE(r.ok());
  const ConfigPlan& p = *r.plan;
  EXPECT_EQ(p.node_id, 32);
  EXPECT_EQ(find_write(p, 0x3000, 0)->write.value, 9u);
  EXPECT_EQ(find_write(p, 0x3001, 0)->write.value, 4u);
  EXPECT_EQ(p.steps.back().kind, StepKind::store);
  EXPECT_EQ(p.steps.back().store[0].sub, 1);
  EXPECT_EQ(p.store_policy, config::StorePolicy::always);

  const Fixture rsx = load("novotechnik-rsx7900-1ch.eds");
  r = make_node_id_plan("arm", rsx.eds, rsx.profile, 127, 20);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(find_write(*r.plan, 0x2000, 0)->write.value, 20u);
  EXPECT_EQ(r.plan->steps.back().store[0].sub, 1);
  const Fixture rfc = load("novotechnik-rfc4800-1ch.eds");
  r = make_node_id_plan("arm", rfc.eds, rfc.profile, 127, 20, 100);
  ASSERT_FALSE(r.ok());  // J§1.2.2: no 100 kbit/s
  EXPECT_EQ(r.errors[0].setting, "bitrate");
}

// The fingerprint: stable for equal settings, independent of the node-ID and
// of the order CAMs are listed in, different when a value changes.
TEST(ConfigPlan, FingerprintIsStableAndSensitive) {
  const Fixture f = load("novotechnik-multiturn.eds");
  config::Device d = device_named("lift");
  config::Cam a;
  a.index = 1;
  a.low = 1;
  config::Cam b;
  b.index = 2;
  b.low = 2;
  d.cams = {a, b};
  d.preset = 5;
  const ConfigPlan p1 = plan_ok(d, f, 5);
  const ConfigPlan p2 = plan_ok(d, f, 9);
  EXPECT_EQ(p1.fingerprint, p2.fingerprint);
  config::Device swapped = d;
  swapped.cams = {b, a};
  EXPECT_EQ(plan_ok(swapped, f).fingerprint, p1.fingerprint);
  config::Device changed = d;
  changed.preset = 6;
  EXPECT_NE(plan_ok(changed, f).fingerprint, p1.fingerprint);
  config::Device policy = d;
  policy.store = config::StorePolicy::always;
  EXPECT_NE(plan_ok(policy, f).fingerprint, p1.fingerprint);
  EXPECT_EQ(p1.fingerprint, fingerprint_text(p1.fingerprint_value));
}

// FNV-1a 64 reference values (offset basis; "a" from the published test vectors).
TEST(ConfigPlan, Fnv1a64ReferenceValues) {
  EXPECT_EQ(fnv1a64(nullptr, 0), 0xcbf29ce484222325ull);
  EXPECT_EQ(fnv1a64("a", 1), 0xaf63dc4c8601ec8cull);
  EXPECT_EQ(fingerprint_text(0xaf63dc4c8601ec8cull), "af63dc4c8601ec8c");
}


// ---- command plans (plugin ABI 2 commands) ------------------------------------

ConfigPlanResult command(const Fixture& f, CommandKind kind, std::int64_t value = 0) {
  return make_command_plan("axis", f.eds, f.profile, 7, kind, value);
}

// J§1.3.2: the rotary series presets each channel (0x6010/ch, INTEGER32);
// a preset always writes (no compare first) and reads back.
TEST(CommandPlan, J1_3_2_RotaryPresetWritesEveryChannel) {
  const Fixture f = load("novotechnik-rfc4800-2ch.eds");
  const ConfigPlanResult r = command(f, CommandKind::preset, -1000);
  ASSERT_TRUE(r.ok()) << error_texts(r).front();
  ASSERT_EQ(r.plan->steps.size(), 2u);
  for (std::uint8_t ch = 1; ch <= 2; ++ch) {
    const PlanStep& s = r.plan->steps[ch - 1u];
    EXPECT_EQ(s.kind, StepKind::write);
    EXPECT_EQ(s.write.index, 0x6010);
    EXPECT_EQ(s.write.sub, ch);
    EXPECT_EQ(s.write.size, 4);
    EXPECT_EQ(s.write.value, static_cast<std::uint32_t>(-1000));
    EXPECT_FALSE(s.write.read_first);
    EXPECT_TRUE(s.write.verify);
  }
  EXPECT_EQ(r.plan->store_policy, config::StorePolicy::never);
  EXPECT_EQ(r.plan->node_id, 7);
}

// E§4.2 / F§7.5: 0x6003 (UNSIGNED32): a negative preset is out of range and
// says so, flagged for the caller (Modbus: command_status 7).
TEST(CommandPlan, E4_2_PresetOutsideTheObjectIsOutOfRange) {
  const Fixture f = load("novotechnik-multiturn.eds");
  const ConfigPlanResult ok = command(f, CommandKind::preset, 4096);
  ASSERT_TRUE(ok.ok());
  ASSERT_EQ(ok.plan->steps.size(), 1u);
  EXPECT_EQ(ok.plan->steps[0].write.index, 0x6003);
  EXPECT_EQ(ok.plan->steps[0].write.value, 4096u);

  const ConfigPlanResult bad = command(f, CommandKind::preset, -1);
  ASSERT_FALSE(bad.ok());
  ASSERT_EQ(bad.errors.size(), 1u);
  EXPECT_TRUE(bad.errors[0].out_of_range);
  EXPECT_NE(bad.errors[0].to_string().find("-1 is outside 0..4294967295 of object 0x6003"), std::string::npos)
      << bad.errors[0].to_string();
}

// CiA 301 §7.2.8.3.1.1: NMT reset node, nothing else.
TEST(CommandPlan, NmtResetIsOneNmtStep) {
  const Fixture f = load("ifm-rm8-rm9.eds");
  const ConfigPlanResult r = command(f, CommandKind::nmt_reset);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r.plan->steps.size(), 1u);
  EXPECT_EQ(r.plan->steps[0].kind, StepKind::nmt);
  EXPECT_EQ(r.plan->steps[0].nmt, canopen::NmtCommand::reset_node);
}

// E§11: 'save' only in pre-operational, communication with /2 and
// application with /3 on the multiturn series; started again afterwards.
TEST(CommandPlan, E11_StorePassesThroughPreOperational) {
  const Fixture f = load("novotechnik-multiturn.eds");
  const ConfigPlanResult r = command(f, CommandKind::store);
  ASSERT_TRUE(r.ok()) << error_texts(r).front();
  const auto& steps = r.plan->steps;
  ASSERT_EQ(steps.size(), 3u);
  EXPECT_EQ(steps[0].nmt, canopen::NmtCommand::enter_preop);
  ASSERT_EQ(steps[1].kind, StepKind::store);
  std::vector<std::uint8_t> subs;
  for (const StoreTarget& t : steps[1].store) subs.push_back(t.sub);
  EXPECT_EQ(subs, (std::vector<std::uint8_t>{f.profile.store.communication, f.profile.store.application}));
  EXPECT_EQ(steps[2].nmt, canopen::NmtCommand::start);
  EXPECT_EQ(r.plan->store_policy, config::StorePolicy::always);
}

// F§7.3: ifm's 0x1010 has sub-index 1 only: one 'save' for both groups.
TEST(CommandPlan, F7_3_IfmStoreIsOneSave) {
  const Fixture f = load("ifm-rm8-rm9.eds");
  const ConfigPlanResult r = command(f, CommandKind::store);
  ASSERT_TRUE(r.ok()) << error_texts(r).front();
  const auto it = std::find_if(r.plan->steps.begin(), r.plan->steps.end(),
                               [](const PlanStep& s) { return s.kind == StepKind::store; });
  ASSERT_NE(it, r.plan->steps.end());
  ASSERT_EQ(it->store.size(), 1u);
  EXPECT_EQ(it->store[0].sub, 1);
  EXPECT_EQ(it->store[0].groups, bit(StoreGroup::communication) | bit(StoreGroup::application));
}

}  // namespace
}  // namespace cobridge::bus
