// FamilyProfile: each family fact against its manual section, and every
// object a profile names against the shipped EDS files.
#include "device/family_profile.hpp"

#include <gtest/gtest.h>

#include <string>

#include "device/eds.hpp"
#include "families/novotechnik_multiturn.hpp"
#include "families/novotechnik_rotary.hpp"
#include "unit/device/source_paths.hpp"

namespace cobridge::device {
namespace {

using families::FamilyId;

DeviceDescription load(const std::string& file) {
  EdsResult r = load_eds_file(test::shipped_devices_dir() / file);
  EXPECT_TRUE(r.ok()) << file << ": " << (r.errors.empty() ? "" : r.errors.front().to_string());
  return r.ok() ? *r.description : DeviceDescription{};
}

FamilyProfile rotary1() { return make_family_profile(FamilyId::novotechnik_rotary, 1); }
FamilyProfile rotary2() { return make_family_profile(FamilyId::novotechnik_rotary, 2); }
FamilyProfile multiturn() { return make_family_profile(FamilyId::novotechnik_multiturn); }
FamilyProfile ifm() { return make_family_profile(FamilyId::ifm_rm); }

// A profile names its family's module (the one identity, daemon/families).
TEST(FamilyProfile, ProfileNamesItsFamilyModule) {
  EXPECT_EQ(rotary1().family, &families::kNovotechnikRotary);
  EXPECT_EQ(multiturn().family, &families::kNovotechnikMultiturn);
  EXPECT_EQ(ifm().family, &families::kIfmRm);
  EXPECT_TRUE(ifm().is(FamilyId::ifm_rm));
  EXPECT_FALSE(ifm().is(FamilyId::novotechnik_rotary));
}

// J§1.3.2: 0x6020/0 is the number of channels; J§1.2.1 / J§1.12 V10: RSX-7900
// and RFX-6900 are the legacy firmware.
TEST(FamilyProfile, J1_3_2_ChannelsAndLegacyFromShippedEds) {
  auto p1 = family_profile_for(load("novotechnik-rfc4800-1ch.eds"));
  ASSERT_TRUE(p1);
  EXPECT_TRUE(p1->is(FamilyId::novotechnik_rotary));
  EXPECT_EQ(p1->channels, 1);
  EXPECT_FALSE(p1->legacy_rsx_rfx);
  auto p2 = family_profile_for(load("novotechnik-rfc4800-2ch.eds"));
  ASSERT_TRUE(p2);
  EXPECT_EQ(p2->channels, 2);
  auto rsx = family_profile_for(load("novotechnik-rsx7900-1ch.eds"));
  ASSERT_TRUE(rsx);
  EXPECT_TRUE(rsx->legacy_rsx_rfx);
  auto rfx = family_profile_for(load("novotechnik-rfx6900-2ch.eds"));
  ASSERT_TRUE(rfx);
  EXPECT_TRUE(rfx->legacy_rsx_rfx);
  EXPECT_EQ(rfx->channels, 2);
  auto mt = family_profile_for(load("novotechnik-multiturn.eds"));
  ASSERT_TRUE(mt);
  EXPECT_TRUE(mt->is(FamilyId::novotechnik_multiturn));
  auto rm = family_profile_for(load("ifm-rm8-rm9.eds"));
  ASSERT_TRUE(rm);
  EXPECT_TRUE(rm->is(FamilyId::ifm_rm));
  DeviceDescription none;
  EXPECT_FALSE(family_profile_for(none));
}

// J§1.3.2 0x6020/ch INTEGER32; E§4.2 0x6004 INTEGER32 plus the 0x6020/1 alias
// of the default mapping (E§4.1 0x1A00/1); F§7.5 0x6004 UNSIGNED32 with the
// limit-switch bits 30/31 (F§7.4 0x2104/0x2105).
TEST(FamilyProfile, PositionObjectPerFamily_J1_3_2_E4_2_F7_5) {
  EXPECT_EQ(rotary2().position(1), (ObjectRef{0x6020, 1}));
  EXPECT_EQ(rotary2().position(2), (ObjectRef{0x6020, 2}));
  EXPECT_EQ(rotary1().position_type, DataType::kInteger32);
  EXPECT_FALSE(rotary1().position_alias);

  EXPECT_EQ(multiturn().position(), (ObjectRef{0x6004, 0}));
  EXPECT_EQ(multiturn().position_alias, (ObjectRef{0x6020, 1}));
  EXPECT_TRUE(multiturn().is_position_entry(0x60200120));
  EXPECT_TRUE(multiturn().is_position_entry(0x60040020));
  EXPECT_FALSE(multiturn().is_position_entry(0x60300110));

  EXPECT_EQ(ifm().position(), (ObjectRef{0x6004, 0}));
  EXPECT_EQ(ifm().position_type, DataType::kUnsigned32);
  EXPECT_EQ(ifm().position_value_mask, 0x3FFFFFFFu);
  EXPECT_EQ(ifm().limit_switch_min_bit, 30);
  EXPECT_EQ(ifm().limit_switch_max_bit, 31);
  EXPECT_FALSE(ifm().is_position_entry(0x60200120));
}

// E§3.4: speed in 0.1 °/s; F§7.4: 0x3011 in digits/s, off until 0x3010/1 = 1.
TEST(FamilyProfile, SpeedUnitAndEnable_E3_4_F7_4) {
  EXPECT_EQ(multiturn().speed(), (ObjectRef{0x6030, 1}));
  EXPECT_EQ(multiturn().speed_unit, SpeedUnit::deci_degree_per_s);
  EXPECT_FALSE(multiturn().speed_enable);
  EXPECT_EQ(rotary2().speed(2), (ObjectRef{0x6030, 2}));
  EXPECT_EQ(ifm().speed_unit, SpeedUnit::digits_per_s);
  EXPECT_EQ(ifm().speed_enable, (ObjectRef{0x3010, 1}));
}

// J§1.7.2 mapping examples: 0x60200120 (position ch1), 0x60300110 (speed ch1).
TEST(FamilyProfile, J1_7_2_RotarySignalMapping) {
  const auto p = rotary2();
  EXPECT_EQ(p.mapping_entry(config::Signal::position).entry, 0x60200120u);
  EXPECT_EQ(p.mapping_entry(config::Signal::position, 2).entry, 0x60200220u);
  EXPECT_EQ(p.mapping_entry(config::Signal::speed).entry, 0x60300110u);
  EXPECT_EQ(p.mapping_entry(config::Signal::cam).entry, 0x63000108u);
  EXPECT_EQ(p.mapping_entry(config::Signal::work_area, 2).entry, 0x64000208u);
  EXPECT_EQ(p.mapping_entry(config::Signal::alarms).entry, 0x65030010u);
  EXPECT_EQ(p.mapping_entry(config::Signal::warnings).entry, 0x65050010u);
  const auto t = p.mapping_entry(config::Signal::temperature);
  EXPECT_FALSE(t.ok());
  EXPECT_NE(t.error.find("E§4.3"), std::string_view::npos);
  EXPECT_FALSE(rotary1().mapping_entry(config::Signal::position, 2).ok());
}

// E§8.2 mappable objects.
TEST(FamilyProfile, E8_2_MultiturnSignalMapping) {
  const auto p = multiturn();
  EXPECT_EQ(p.mapping_entry(config::Signal::position).entry, 0x60040020u);
  EXPECT_EQ(p.mapping_entry(config::Signal::speed).entry, 0x60300110u);
  EXPECT_EQ(p.mapping_entry(config::Signal::temperature).entry, 0x20020010u);
  EXPECT_EQ(p.mapping_entry(config::Signal::voltage).entry, 0x20030010u);
  EXPECT_EQ(p.mapping_entry(config::Signal::alarms).entry, 0x65030010u);
}

// F§4: "alarms and warnings are not indicated"; F§7.5 romap objects.
TEST(FamilyProfile, F4_IfmLacksAlarmsWarningsTemperature) {
  const auto p = ifm();
  EXPECT_EQ(p.mapping_entry(config::Signal::position).entry, 0x60040020u);
  EXPECT_EQ(p.mapping_entry(config::Signal::cam).entry, 0x63000108u);
  const auto a = p.mapping_entry(config::Signal::alarms);
  EXPECT_FALSE(a.ok());
  EXPECT_NE(a.error.find("F§4"), std::string_view::npos);
  EXPECT_FALSE(p.mapping_entry(config::Signal::warnings).ok());
  EXPECT_FALSE(p.mapping_entry(config::Signal::temperature).ok());
  EXPECT_FALSE(p.mapping_entry(config::Signal::voltage).ok());
}

// J§1.3.3 / E§4.3: 0x2000 value = node-ID; F§7.4 0x3000: "always add 1"
// (1Fh + 1 = 32).
TEST(FamilyProfile, NodeIdEncoding_J1_3_3_E4_3_F7_4) {
  EXPECT_EQ(rotary1().node_id_object, (ObjectRef{0x2000, 0}));
  EXPECT_EQ(rotary1().encode_node_id(64), 64u);
  EXPECT_EQ(multiturn().encode_node_id(127), 127u);
  EXPECT_EQ(ifm().node_id_object, (ObjectRef{0x3000, 0}));
  EXPECT_EQ(ifm().encode_node_id(32), 0x1Fu);
  EXPECT_EQ(ifm().decode_node_id(0x1F), 32);
  EXPECT_EQ(ifm().encode_node_id(1), 0u);
  EXPECT_EQ(ifm().decode_node_id(126), 127);
  EXPECT_EQ(rotary1().decode_node_id(0x7F), 127);
}

// J§1.3.3 0x2001 kbit/s (ordering codes J§1.2.2); F§7.4 0x3001 index 0..7 =
// 20/50/100/125/250/500/800/1000 (ascending, unlike CiA 305).
TEST(FamilyProfile, BitRateEncoding_J1_3_3_F7_4) {
  EXPECT_EQ(rotary1().bitrate_object, (ObjectRef{0x2001, 0}));
  EXPECT_EQ(rotary1().encode_bitrate(250), 250u);
  EXPECT_EQ(rotary1().encode_bitrate(100), std::nullopt);
  EXPECT_EQ(multiturn().decode_bitrate(0x00FA), 250);
  EXPECT_EQ(ifm().bitrate_object, (ObjectRef{0x3001, 0}));
  EXPECT_EQ(ifm().encode_bitrate(20), 0u);
  EXPECT_EQ(ifm().encode_bitrate(125), 3u);
  EXPECT_EQ(ifm().encode_bitrate(1000), 7u);
  EXPECT_EQ(ifm().encode_bitrate(10), std::nullopt);
  EXPECT_EQ(ifm().decode_bitrate(2), 100);
  EXPECT_EQ(ifm().decode_bitrate(8), std::nullopt);
}

// 0x6000 bit 2: J§1.4.1 1 = scaling on; E§5.3 0 = scaling on (as printed);
// F§7.5 SFC 1 = enabled.
TEST(FamilyProfile, ScalingBitPolarity_J1_4_1_E5_3_F7_5) {
  EXPECT_EQ(rotary1().scaling_bit(true), 0x4u);
  EXPECT_EQ(rotary1().scaling_bit(false), 0x0u);
  EXPECT_EQ(multiturn().scaling_bit(true), 0x0u);
  EXPECT_EQ(multiturn().scaling_bit(false), 0x4u);
  EXPECT_EQ(ifm().scaling_bit(true), 0x4u);
}

// J§1.10 (V10 notes) and J§1.6.1: application /3, communication /2, node-ID
// /4 (RSX/RFX /1); E§11 table and E§7.1: /2, /3, /4; F§7.3: only /1; F§6.3.4
// save with reset 0x2300 <- 0x55AAAA55. 'save' = 73 61 76 65 (J§1.6.1).
TEST(FamilyProfile, StoreSubIndices_J1_10_E11_F6_3) {
  EXPECT_EQ(rotary1().store.communication, 2);
  EXPECT_EQ(rotary1().store.application, 3);
  EXPECT_EQ(rotary1().store.node_id, 4);
  EXPECT_EQ(make_family_profile(FamilyId::novotechnik_rotary, 1, true).store.node_id, 1);
  EXPECT_EQ(multiturn().store.communication, 2);
  EXPECT_EQ(multiturn().store.application, 3);
  EXPECT_EQ(multiturn().store.node_id, 4);
  EXPECT_EQ(ifm().store.communication, 1);
  EXPECT_EQ(ifm().store.application, 1);
  EXPECT_EQ(ifm().store.node_id, 1);
  EXPECT_TRUE(rotary1().store_only_pre_operational);
  EXPECT_FALSE(rotary1().save_with_reset);
  EXPECT_EQ(ifm().save_with_reset, (ObjectRef{0x2300, 0}));
  EXPECT_EQ(kIfmSaveWithResetCode, 0x55AAAA55u);
  EXPECT_EQ(kSaveSignature & 0xFF, 0x73u);  // 's' first on the wire
  EXPECT_EQ(kSaveSignature >> 24, 0x65u);   // 'e' last
  EXPECT_FALSE(ifm().cams_stored);           // F§6.3.1 lists no 0x63xx object
}

// J§1.2.2 "heartbeat: no" vs 0x1017 in J§1.3.1; E§3.1 heartbeat producer.
TEST(FamilyProfile, Heartbeat_J1_2_2_E3_1) {
  EXPECT_EQ(rotary1().heartbeat, HeartbeatSupport::uncertain);
  EXPECT_EQ(multiturn().heartbeat, HeartbeatSupport::yes);
  EXPECT_EQ(ifm().heartbeat, HeartbeatSupport::yes);
}

// J§1.7.2 / E§8.2: at most 5 entries and 8 bytes per PDO; J§1.3.1 0x1801/2:
// TPDO2 synchronous only; F§7.3: RTR types 252/253.
TEST(FamilyProfile, PdoLimitsAndTransmissionTypes_J1_7_2_J1_3_1_F7_3) {
  EXPECT_EQ(rotary1().max_pdo_entries, 5);
  EXPECT_EQ(rotary1().max_pdo_bytes, 8);
  EXPECT_EQ(multiturn().max_pdo_entries, 5);
  EXPECT_TRUE(rotary1().transmission_type_allowed(1, 254));
  EXPECT_TRUE(rotary1().transmission_type_allowed(1, 255));
  EXPECT_TRUE(rotary1().transmission_type_allowed(2, 1));
  EXPECT_FALSE(rotary1().transmission_type_allowed(2, 254));
  EXPECT_FALSE(rotary1().transmission_type_allowed(1, 252));
  EXPECT_FALSE(rotary1().transmission_type_allowed(3, 1));
  EXPECT_TRUE(ifm().transmission_type_allowed(1, 252));
  EXPECT_TRUE(ifm().transmission_type_allowed(2, 254));
  EXPECT_FALSE(ifm().transmission_type_allowed(1, 245));
}

// J§1.2.3: 4 CAMs per channel (configuration 5..8 = channel 2); E§3.4: 4 CAMs;
// F§7.5: CAMs 1 to 8. Objects 0x631x/0x632x/0x633x per J§1.3.2.
TEST(FamilyProfile, CamCountsAndObjects_J1_2_3_E3_4_F7_5) {
  EXPECT_EQ(rotary1().cams_per_channel, 4);
  EXPECT_TRUE(rotary1().cam_slot(4));
  EXPECT_FALSE(rotary1().cam_slot(5));
  const auto s6 = rotary2().cam_slot(6);
  ASSERT_TRUE(s6);
  EXPECT_EQ(s6->channel, 2);
  EXPECT_EQ(s6->number, 2);
  EXPECT_EQ(FamilyProfile::cam_low(*s6), (ObjectRef{0x6311, 2}));
  EXPECT_EQ(FamilyProfile::cam_high(*s6), (ObjectRef{0x6321, 2}));
  EXPECT_EQ(FamilyProfile::cam_hysteresis(*s6), (ObjectRef{0x6331, 2}));
  EXPECT_FALSE(rotary2().cam_slot(9));
  EXPECT_FALSE(multiturn().cam_slot(5));
  EXPECT_EQ(multiturn().cam_limit_text(), "the multiturn series has 4 CAMs (E§3.4)");
  const auto s8 = ifm().cam_slot(8);
  ASSERT_TRUE(s8);
  EXPECT_EQ(s8->channel, 1);
  EXPECT_EQ(FamilyProfile::cam_low(*s8), (ObjectRef{0x6317, 1}));
  EXPECT_FALSE(ifm().cam_slot(9));
  EXPECT_FALSE(ifm().cam_slot(0));
  EXPECT_EQ(FamilyProfile::cam_enable(1), (ObjectRef{0x6301, 1}));
  EXPECT_EQ(FamilyProfile::cam_polarity(2), (ObjectRef{0x6302, 2}));
  EXPECT_EQ(FamilyProfile::work_area_low(1), (ObjectRef{0x6401, 1}));
  EXPECT_EQ(FamilyProfile::work_area_high(2), (ObjectRef{0x6402, 2}));
}

// J§1.3.2 0x6010/ch INTEGER32; E§4.2 / F§7.5 0x6003 UNSIGNED32. Filters:
// J§1.4.1 bits 14..12, E§5.1/E§5.2 0x2010/1, /2, none on ifm.
TEST(FamilyProfile, PresetAndFilters_J1_4_1_E5_1_E5_2) {
  EXPECT_EQ(rotary2().preset(2), (ObjectRef{0x6010, 2}));
  EXPECT_EQ(rotary2().preset_type(), DataType::kInteger32);
  EXPECT_EQ(multiturn().preset(), (ObjectRef{0x6003, 0}));
  EXPECT_EQ(ifm().preset_type(), DataType::kUnsigned32);
  EXPECT_TRUE(rotary1().position_filter_in_operating_parameter);
  EXPECT_FALSE(rotary1().position_filter);
  EXPECT_EQ(multiturn().position_filter, (ObjectRef{0x2010, 1}));
  EXPECT_EQ(multiturn().speed_filter, (ObjectRef{0x2010, 2}));
  EXPECT_FALSE(ifm().position_filter);
  EXPECT_FALSE(ifm().position_filter_in_operating_parameter);
  EXPECT_EQ(ifm().event_timer_alias, (ObjectRef{0x6200, 0}));
}

// J§1.8: 0x7FF0; E§9.1: 0x7FFFFFFC, 0x7FFFFFF8, 0x80000008; F documents none.
TEST(FamilyProfile, ErrorPositions_J1_8_E9_1) {
  EXPECT_TRUE(rotary1().is_error_position(0x7FF0));
  EXPECT_FALSE(rotary1().is_error_position(0x3FFF));
  EXPECT_TRUE(multiturn().is_error_position(0x7FFFFFFC));
  EXPECT_TRUE(multiturn().is_error_position(0x7FFFFFF8));
  EXPECT_TRUE(multiturn().is_error_position(-2147483640));
  EXPECT_FALSE(multiturn().is_error_position(0x7FF0));
  EXPECT_TRUE(ifm().error_positions.empty());
}

// Every object a profile names exists in the shipped EDS of its family, and
// every semantic mapping entry has the EDS object's bit length and is
// PDO-mappable there (J§1.7.2, E§8.2, F§7.5 romap).
void expect_objects_in_eds(const std::string& file) {
  SCOPED_TRACE(file);
  const DeviceDescription d = load(file);
  const auto p = family_profile_for(d);
  ASSERT_TRUE(p);
  auto has = [&d](ObjectRef o) { return d.find(o.index, o.sub) != nullptr; };
  for (std::uint8_t ch = 1; ch <= p->channels; ++ch) {
    EXPECT_TRUE(has(p->position(ch)));
    EXPECT_TRUE(has(p->speed(ch)));
    EXPECT_TRUE(has(p->preset(ch)));
    EXPECT_TRUE(has(FamilyProfile::cam_enable(ch)));
    EXPECT_TRUE(has(FamilyProfile::cam_polarity(ch)));
    EXPECT_TRUE(has(FamilyProfile::work_area_low(ch)));
    EXPECT_TRUE(has(FamilyProfile::work_area_high(ch)));
  }
  for (std::uint8_t cam = 1; cam <= p->cams_per_channel * p->channels; ++cam) {
    const auto slot = p->cam_slot(cam);
    ASSERT_TRUE(slot) << "cam " << int{cam};
    EXPECT_TRUE(has(FamilyProfile::cam_low(*slot))) << "cam " << int{cam};
    EXPECT_TRUE(has(FamilyProfile::cam_high(*slot))) << "cam " << int{cam};
    EXPECT_TRUE(has(FamilyProfile::cam_hysteresis(*slot))) << "cam " << int{cam};
  }
  EXPECT_TRUE(has(p->node_id_object));
  EXPECT_TRUE(has(p->bitrate_object));
  EXPECT_TRUE(has({0x1010, p->store.communication}));
  EXPECT_TRUE(has({0x1010, p->store.application}));
  EXPECT_TRUE(has({0x1010, p->store.node_id}));
  EXPECT_TRUE(has({0x1017, 0}));
  EXPECT_TRUE(has({0x100C, 0}));
  if (p->save_with_reset) { EXPECT_TRUE(has(*p->save_with_reset)); }
  if (p->speed_enable) { EXPECT_TRUE(has(*p->speed_enable)); }
  if (p->position_filter) { EXPECT_TRUE(has(*p->position_filter)); }
  if (p->speed_filter) { EXPECT_TRUE(has(*p->speed_filter)); }
  if (p->event_timer_alias) { EXPECT_TRUE(has(*p->event_timer_alias)); }
  const config::Signal signals[] = {config::Signal::position, config::Signal::speed,  config::Signal::cam,
                                    config::Signal::work_area, config::Signal::alarms, config::Signal::warnings,
                                    config::Signal::temperature, config::Signal::voltage};
  for (config::Signal s : signals) {
    const SignalMapping m = p->mapping_entry(s);
    if (!m.ok()) continue;
    const ObjectDesc* o = d.find(static_cast<std::uint16_t>(m.entry >> 16), static_cast<std::uint8_t>(m.entry >> 8));
    ASSERT_NE(o, nullptr) << std::hex << m.entry;
    EXPECT_TRUE(o->pdo_mapping) << std::hex << m.entry;
    EXPECT_EQ(o->bits(), m.entry & 0xFFu) << std::hex << m.entry;
  }
}

TEST(FamilyProfile, ObjectsExistInShippedEds_RotaryJ1_3) { expect_objects_in_eds("novotechnik-rfc4800-1ch.eds"); }
TEST(FamilyProfile, ObjectsExistInShippedEds_Rotary2chJ1_3) { expect_objects_in_eds("novotechnik-rsa3200-2ch.eds"); }
TEST(FamilyProfile, ObjectsExistInShippedEds_RsxJ1_3) { expect_objects_in_eds("novotechnik-rsx7900-1ch.eds"); }
TEST(FamilyProfile, ObjectsExistInShippedEds_MultiturnE4) { expect_objects_in_eds("novotechnik-multiturn.eds"); }
TEST(FamilyProfile, ObjectsExistInShippedEds_IfmF7) { expect_objects_in_eds("ifm-rm8-rm9.eds"); }

}  // namespace
}  // namespace cobridge::device
