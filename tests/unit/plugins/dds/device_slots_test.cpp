// DeviceSlots: the DDS plugin's per-device state, fed the sample kinds of
// cobridge/plugin.h. Which samples change DeviceStatus, and the cut of
// over-long names.
#include "dds/device_slots.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <string>

using namespace cobridge::dds;

namespace {

cobridge_sample sample(std::uint8_t kind) {
  cobridge_sample s{};
  s.device_index = 2;
  s.bus_index = 1;
  s.node_id = 9;
  s.kind = kind;
  s.rx_timestamp_ns = 1000;
  return s;
}

// CiA 301 §7.2.8.3.2: a heartbeat makes the node online with its NMT state;
// a repeat of the same heartbeat changes nothing (no DeviceStatus write).
TEST(DeviceSlots, Cia301_7_2_8_3_2_HeartbeatSetsOnlineAndStateOnce) {
  DeviceSlots slots(8);
  cobridge_sample hb = sample(COBRIDGE_SAMPLE_HEARTBEAT);
  hb.nmt_state = COBRIDGE_NMT_OPERATIONAL;
  hb.valid = COBRIDGE_VALID_NMT_STATE;
  EXPECT_EQ(slots.apply(hb), StatusChange::kChanged);
  const DeviceSlot* slot = slots.find(2);
  ASSERT_NE(slot, nullptr);
  EXPECT_TRUE(slot->in_use);
  EXPECT_EQ(slot->bus_index, 1);
  EXPECT_EQ(slot->node_id, 9);
  EXPECT_TRUE(slot->state.online);
  EXPECT_EQ(slot->state.nmt_state, COBRIDGE_NMT_OPERATIONAL);
  hb.rx_timestamp_ns = 2000;
  EXPECT_EQ(slots.apply(hb), StatusChange::kNone);
  EXPECT_EQ(slot->state.updated_ns, 1000u);
}

// Staleness: STATUS stale=1 is reported as "became stale" once; the
// next TPDO clears it (a fresh value is current).
TEST(DeviceSlots, Cia301_7_2_2_StaleUntilTheNextTpdo) {
  DeviceSlots slots(8);
  cobridge_sample t = sample(COBRIDGE_SAMPLE_TPDO);
  t.position = 77;
  EXPECT_EQ(slots.apply(t), StatusChange::kNone);
  cobridge_sample st = sample(COBRIDGE_SAMPLE_STATUS);
  st.valid = COBRIDGE_VALID_STATUS;
  st.stale = 1;
  st.online = 1;
  EXPECT_EQ(slots.apply(st), StatusChange::kBecameStale);
  EXPECT_TRUE(slots.find(2)->has_last_tpdo);
  EXPECT_EQ(slots.find(2)->last_tpdo.position, 77);
  EXPECT_EQ(slots.apply(st), StatusChange::kNone);
  EXPECT_EQ(slots.apply(t), StatusChange::kChanged);
  EXPECT_FALSE(slots.find(2)->state.stale);
}

// docs/dds.md "Threads and cost", the status lane: a status sample applied
// ahead of the queue (the status lane) changes DeviceStatus at once; when the
// queue reaches it, it is skipped, and the samples queued before it (older than
// the state shown: a TPDO, a heartbeat) neither end `stale` nor bring the
// device back online; the TPDOs after it end `stale`.
TEST(DeviceSlots, DocsDds_StatusAheadOfTheQueueIsAppliedOnce) {
  DeviceSlots slots(8);
  cobridge_sample hb = sample(COBRIDGE_SAMPLE_HEARTBEAT);
  hb.nmt_state = COBRIDGE_NMT_OPERATIONAL;
  hb.valid = COBRIDGE_VALID_NMT_STATE;
  hb.sequence = 1;
  EXPECT_EQ(slots.apply(hb), StatusChange::kChanged);
  cobridge_sample older = sample(COBRIDGE_SAMPLE_TPDO);
  older.sequence = 2;
  cobridge_sample old_hb = hb;
  old_hb.sequence = 3;
  cobridge_sample lost = sample(COBRIDGE_SAMPLE_STATUS);
  lost.valid = COBRIDGE_VALID_STATUS;
  lost.online = 0;
  lost.stale = 1;
  lost.rx_timestamp_ns = 5000;
  lost.sequence = 4;
  cobridge_sample newer = older;
  newer.sequence = 5;
  // The lane: offline and stale now, whatever is queued before it.
  EXPECT_EQ(slots.apply_ahead(lost), StatusChange::kBecameStale);
  EXPECT_FALSE(slots.find(2)->state.online);
  EXPECT_EQ(slots.apply_ahead(older), StatusChange::kNone) << "only status samples take the lane";
  // The queue: what was queued before the loss changes nothing.
  EXPECT_EQ(slots.apply(older), StatusChange::kNone);
  EXPECT_EQ(slots.apply(old_hb), StatusChange::kNone);
  EXPECT_TRUE(slots.find(2)->state.stale);
  EXPECT_FALSE(slots.find(2)->state.online);
  EXPECT_EQ(slots.apply(lost), StatusChange::kNone) << "applied ahead already";
  EXPECT_EQ(slots.find(2)->state.updated_ns, 5000u);
  // A TPDO after the loss is fresh again.
  EXPECT_EQ(slots.apply(newer), StatusChange::kChanged);
  EXPECT_FALSE(slots.find(2)->state.stale);
  EXPECT_FALSE(slots.find(2)->ahead);
}

// docs/dds.md "Threads and cost", the status lane. The lane may drop (full): a
// later status it never carried is applied in queue order as before. And the
// lane may see a sample the queue has taken already (pushed one after the
// other): that changes nothing later on.
TEST(DeviceSlots, DocsDds_LaneDropsAndLateLaneSamplesAreHarmless) {
  DeviceSlots slots(8);
  cobridge_sample on = sample(COBRIDGE_SAMPLE_STATUS);
  on.valid = COBRIDGE_VALID_STATUS;
  on.online = 1;
  on.sequence = 1;
  cobridge_sample off = on;
  off.online = 0;
  off.sequence = 2;
  EXPECT_EQ(slots.apply_ahead(on), StatusChange::kChanged);
  EXPECT_EQ(slots.apply(on), StatusChange::kNone);
  EXPECT_EQ(slots.apply(off), StatusChange::kChanged) << "not in the lane: applied in queue order";
  EXPECT_FALSE(slots.find(2)->state.online);

  cobridge_sample stale = on;
  stale.stale = 1;
  stale.sequence = 3;
  EXPECT_EQ(slots.apply(stale), StatusChange::kBecameStale);
  EXPECT_EQ(slots.apply_ahead(stale), StatusChange::kNone) << "the queue took it first";
  cobridge_sample t = sample(COBRIDGE_SAMPLE_TPDO);
  t.sequence = 4;
  EXPECT_EQ(slots.apply(t), StatusChange::kChanged);
  EXPECT_FALSE(slots.find(2)->state.stale) << "a newer TPDO still ends stale";
}

// Sequences wrap (plugin.h): "newer" is judged modulo 2^32.
TEST(DeviceSlots, PluginH_AheadComparisonSurvivesTheWrap) {
  DeviceSlots slots(8);
  cobridge_sample lost = sample(COBRIDGE_SAMPLE_STATUS);
  lost.valid = COBRIDGE_VALID_STATUS;
  lost.stale = 1;
  lost.sequence = 0xFFFFFFFFu;
  EXPECT_EQ(slots.apply_ahead(lost), StatusChange::kBecameStale);
  cobridge_sample t = sample(COBRIDGE_SAMPLE_TPDO);
  t.sequence = 0xFFFFFFFEu;
  EXPECT_EQ(slots.apply(t), StatusChange::kNone);
  EXPECT_TRUE(slots.find(2)->state.stale);
  t.sequence = 0;  // wrapped: newer
  EXPECT_EQ(slots.apply(t), StatusChange::kChanged);
  EXPECT_FALSE(slots.find(2)->state.stale);
}

// CiA 301 §7.2.7: an EMCY records the last error code and register.
TEST(DeviceSlots, Cia301_7_2_7_EmcyIsTheLastError) {
  DeviceSlots slots(8);
  cobridge_sample e = sample(COBRIDGE_SAMPLE_EMCY);
  e.valid = COBRIDGE_VALID_EMCY;
  e.emcy_code = 0x8130;
  e.emcy_register = 0x11;
  EXPECT_EQ(slots.apply(e), StatusChange::kChanged);
  EXPECT_EQ(slots.find(2)->state.last_emcy_code, 0x8130);
  EXPECT_EQ(slots.find(2)->state.last_emcy_register, 0x11);
  EXPECT_EQ(slots.find(2)->state.last_emcy_ns, 1000u);
}

// Indices beyond the table are ignored, never written.
TEST(DeviceSlots, PluginH_IndexBeyondTableIgnored) {
  DeviceSlots slots(2);
  cobridge_sample t = sample(COBRIDGE_SAMPLE_HEARTBEAT);
  t.device_index = 2;
  EXPECT_EQ(slots.apply(t), StatusChange::kNone);
  EXPECT_EQ(slots.find(2), nullptr);
}

// plugin.h cobridge_device_info: strings are copied and cut at a UTF-8
// character boundary; REMOVED clears the slot.
TEST(DeviceSlots, PluginH_AnnouncementCopiedAndCut) {
  DeviceSlots slots(4);
  std::string long_name(62, 'a');
  long_name += "\xC3\xA9\xC3\xA9";  // "éé": the first straddles the 63-byte limit
  cobridge_device_info d{};
  d.struct_size = sizeof d;
  d.device_index = 1;
  d.node_id = 4;
  d.change = COBRIDGE_DEVICE_ADDED;
  d.name = long_name.c_str();
  d.bus_name = "can0";
  d.model = "";
  d.family = "ifm-rm";
  d.position_unit = "mm";
  DeviceSlot* slot = slots.apply(d);
  ASSERT_NE(slot, nullptr);
  EXPECT_EQ(std::string(slot->name.c_str()), std::string(62, 'a'));
  EXPECT_STREQ(slot->bus_name.c_str(), "can0");
  EXPECT_STREQ(slot->family.c_str(), "ifm-rm");
  d.change = COBRIDGE_DEVICE_REMOVED;
  slots.apply(d);
  EXPECT_FALSE(slots.find(1)->in_use);
  EXPECT_STREQ(slots.find(1)->name.c_str(), "");
}

}  // namespace
