// Unit tests for canopen::SdoServer: the manuals' printed telegrams (J§1.6,
// J§1.7.2, E§7, F§7.2.1) seen from the device side, every abort condition
// with its exact frame, segmented transfers byte for byte, toggles, timeout,
// and the switches (segmented off, size indication, silence, node-ID).
// Fake clock and a recording sink; no sockets, no sleeping.
#include "canopen/sdo_server.hpp"

#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "can/frame_sink.hpp"
#include "canopen/cob_id.hpp"
#include "recording_sink.hpp"

namespace cobridge::canopen {
namespace {

using namespace std::chrono_literals;
using Bytes8 = std::array<uint8_t, 8>;

using test::RecordingSink;

constexpr uint8_t kNode = 0x7F;  // J§1.2.2 / E§3.1 default node-ID
const TimePoint t0 = TimePoint{} + 1h;

// The rotary sensor's dictionary as far as these tests need it (J§1.3.x),
// E's write-only 0x2100 (E§4.3) and F's preset 0x6003 (F§7.5), plus two
// test objects: a rw string (segmented download) and an UNSIGNED24.
void build_od(ObjectDictionary& od) {
  auto add = [&od](const EntryDef& d) { ASSERT_FALSE(od.insert(d)) << d.name; };
  add({.index = 0x1000, .type = DataType::kUnsigned32, .access = Access::kConst, .name = "device type",
       .value = 0x00010196U});
  add({.index = 0x1001, .type = DataType::kUnsigned8, .access = Access::kRo, .name = "error register",
       .value = 0x00});
  add({.index = 0x1008, .type = DataType::kVisibleString, .access = Access::kConst, .name = "device name",
       .text = "RFC-4801-214-614-511"});
  add({.index = 0x1009, .type = DataType::kVisibleString, .access = Access::kConst, .name = "hw version",
       .text = "V 1.00"});
  for (uint16_t index : {uint16_t{0x1010}, uint16_t{0x1011}}) {
    add({.index = index, .sub = 0, .type = DataType::kUnsigned8, .access = Access::kRo, .name = "entries",
         .value = 4});
    for (uint8_t s = 1; s <= 4; ++s)
      add({.index = index, .sub = s, .type = DataType::kUnsigned32, .access = Access::kRw, .name = "signature"});
  }
  add({.index = 0x1018, .sub = 0, .type = DataType::kUnsigned8, .access = Access::kRo, .value = 4});
  add({.index = 0x1018, .sub = 1, .type = DataType::kUnsigned32, .access = Access::kRo, .value = 0x182U});
  add({.index = 0x1A00, .sub = 0, .type = DataType::kUnsigned8, .access = Access::kRw, .value = 2});
  add({.index = 0x1A00, .sub = 1, .type = DataType::kUnsigned32, .access = Access::kRw, .value = 0x60200120U});
  add({.index = 0x1A00, .sub = 2, .type = DataType::kUnsigned32, .access = Access::kRw, .value = 0x60300110U});
  add({.index = 0x2000, .type = DataType::kUnsigned8, .access = Access::kRw, .name = "node-ID", .value = 0x7F,
       .low = 1, .high = 127});
  add({.index = 0x2100, .type = DataType::kBoolean, .access = Access::kWo, .name = "position error reset",
       .value = 1});
  add({.index = 0x2F00, .type = DataType::kVisibleString, .access = Access::kRw, .name = "test text",
       .capacity = 16});
  add({.index = 0x2F01, .type = DataType::kUnsigned24, .access = Access::kRw, .name = "test u24",
       .value = 0x123456});
  add({.index = 0x6000, .type = DataType::kUnsigned16, .access = Access::kRw, .name = "operating parameter",
       .value = 0x0000});
  add({.index = 0x6001, .type = DataType::kUnsigned32, .access = Access::kRw, .name = "units per revolution",
       .value = 0x4000U});
  add({.index = 0x6003, .type = DataType::kUnsigned32, .access = Access::kRw, .name = "preset (F)"});
  add({.index = 0x6020, .sub = 0, .type = DataType::kUnsigned8, .access = Access::kRo, .value = 1});
  add({.index = 0x6020, .sub = 1, .type = DataType::kInteger32, .access = Access::kRo, .pdo_mappable = true,
       .name = "position ch1", .value = 0});
}

class SdoServerTest : public ::testing::Test {
 protected:
  SdoServerTest() { build_od(od_); }

  SdoServer& server(SdoServer::Config config = {}, uint8_t node = kNode) {
    server_.emplace(sink_, od_, node, config);
    return *server_;
  }

  // Sends one request and returns every frame the server sent in reply.
  std::vector<can::Frame> request(const Bytes8& bytes, TimePoint now = t0, uint8_t node = kNode) {
    sink_.frames.clear();
    EXPECT_TRUE(server_->on_frame(can::Frame::make8(cob::kSdoRxBase + node, bytes), now));
    return sink_.frames;
  }

  // Sends one request and expects exactly one reply with these bytes.
  void exchange(const Bytes8& req, const Bytes8& resp, TimePoint now = t0, uint8_t node = kNode) {
    const auto replies = request(req, now, node);
    ASSERT_EQ(replies.size(), 1U);
    EXPECT_EQ(replies[0], can::Frame::make8(cob::kSdoTxBase + node, resp))
        << "request " << ::testing::PrintToString(req) << " got " << ::testing::PrintToString(replies[0].data);
  }

  ObjectDictionary od_;
  RecordingSink sink_;
  std::optional<SdoServer> server_;
};

// --- the manuals' printed telegrams ----------------------------------------------

// J§1.6.1 (= E§7.1): store all parameters, 'save' on 0x1010/1.
TEST_F(SdoServerTest, J_1_6_1_StoreAll) {
  std::vector<uint8_t> subs;
  ASSERT_FALSE(od_.set_hooks(0x1010, Hooks{.on_read = nullptr,
                                           .on_write = [&subs](const WriteRequest& w) -> uint32_t {
                                             if (w.as_unsigned() != 0x65766173U) return 0x08000020U;
                                             subs.push_back(w.sub);
                                             return 0U;
                                           },
                                           .after_write = nullptr}));
  server();
  exchange({0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65}, {0x60, 0x10, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00});
  EXPECT_EQ(subs, std::vector<uint8_t>{1});
  // A wrong signature is refused by the hook: CiA 301 §7.5.2.13 "cannot store".
  exchange({0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x66}, {0x80, 0x10, 0x10, 0x01, 0x20, 0x00, 0x00, 0x08});
}

// J§1.6.1 (= E§7.1): restore all default parameters, 'load' on 0x1011/1.
TEST_F(SdoServerTest, J_1_6_1_RestoreAll) {
  server();
  exchange({0x23, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64}, {0x60, 0x11, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00});
  EXPECT_EQ(od_.get_u32(0x1011, 1), 0x64616F6CU);
}

// E§7.1: set node-ID 0x40 on 0x2000 with a 1-byte download.
TEST_F(SdoServerTest, E_7_1_SetNodeId) {
  server();
  exchange({0x2F, 0x00, 0x20, 0x00, 0x40, 0x00, 0x00, 0x00}, {0x60, 0x00, 0x20, 0x00, 0x00, 0x00, 0x00, 0x00});
  EXPECT_EQ(od_.get_u8(0x2000, 0), 0x40);
}

// J§1.6.1 prints the node-ID request as `23 00 20 80 00 00 00 00` (sub 0x80;
// J§1.6.1). Against a correct dictionary (0x2000 is sub 0 only)
// that frame is refused with "sub-index does not exist".
TEST_F(SdoServerTest, J_1_6_1_MisprintedNodeIdRequestAbortsWithSubIndexMissing) {
  server();
  exchange({0x23, 0x00, 0x20, 0x80, 0x00, 0x00, 0x00, 0x00}, {0x80, 0x00, 0x20, 0x80, 0x11, 0x00, 0x09, 0x06});
  EXPECT_EQ(od_.get_u8(0x2000, 0), 0x7F);
}

// J§1.7.2 (= E§8.2): mapping entries written to 0x1A00/1 and /2.
TEST_F(SdoServerTest, J_1_7_2_MappingWrites) {
  server();
  exchange({0x2F, 0x00, 0x1A, 0x00, 0x00, 0x00, 0x00, 0x00}, {0x60, 0x00, 0x1A, 0x00, 0x00, 0x00, 0x00, 0x00});
  exchange({0x23, 0x00, 0x1A, 0x01, 0x20, 0x01, 0x20, 0x60}, {0x60, 0x00, 0x1A, 0x01, 0x00, 0x00, 0x00, 0x00});
  exchange({0x23, 0x00, 0x1A, 0x02, 0x10, 0x01, 0x30, 0x60}, {0x60, 0x00, 0x1A, 0x02, 0x00, 0x00, 0x00, 0x00});
  EXPECT_EQ(od_.get_u32(0x1A00, 1), 0x60200120U);
  EXPECT_EQ(od_.get_u32(0x1A00, 2), 0x60300110U);
  EXPECT_EQ(od_.get_u8(0x1A00, 0), 0);
}

// F§7.2.1: set and read back the preset on node 1 (the data bytes are 4096,
// not the caption's 1000; F§7.2.1).
TEST_F(SdoServerTest, F_7_2_1_PresetWriteAndReadBackOnNode1) {
  server({}, 1);
  exchange({0x23, 0x03, 0x60, 0x00, 0x00, 0x10, 0x00, 0x00}, {0x60, 0x03, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00}, t0,
           1);
  exchange({0x40, 0x03, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00}, {0x43, 0x03, 0x60, 0x00, 0x00, 0x10, 0x00, 0x00}, t0,
           1);
  EXPECT_EQ(od_.get_u32(0x6003, 0), 4096U);
}

// F§7.2.1 prints the store response as `60 10 10 00 …` (sub 00). CiA 301
// §7.2.4.3.3 has the response echo the request's multiplexer, so the
// simulator answers with sub 01; gateways must accept either (F§7.2.1).
TEST_F(SdoServerTest, F_7_2_1_StoreResponseEchoesRequestSubIndex) {
  server({}, 1);
  exchange({0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65}, {0x60, 0x10, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00}, t0,
           1);
}

// J§1.6.2 / E§7.2 / F§7 command table: 0x43/0x47/0x4B/0x4F for 4/3/2/1 bytes.
TEST_F(SdoServerTest, J_1_6_2_ExpeditedUploadCommandBySize) {
  server();
  exchange({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}, {0x43, 0x00, 0x10, 0x00, 0x96, 0x01, 0x01, 0x00});
  exchange({0x40, 0x01, 0x2F, 0x00, 0, 0, 0, 0}, {0x47, 0x01, 0x2F, 0x00, 0x56, 0x34, 0x12, 0x00});
  ASSERT_EQ(od_.set_u16(0x6000, 0, 0x0104), 0U);
  exchange({0x40, 0x00, 0x60, 0x00, 0, 0, 0, 0}, {0x4B, 0x00, 0x60, 0x00, 0x04, 0x01, 0x00, 0x00});
  exchange({0x40, 0x01, 0x10, 0x00, 0, 0, 0, 0}, {0x4F, 0x01, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00});
  exchange({0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0}, {0x43, 0x18, 0x10, 0x01, 0x82, 0x01, 0x00, 0x00});
}

// J§1.6.2 / E§7.2: 0x42 "unspecified size" when size indication is off.
TEST_F(SdoServerTest, E_7_2_UploadWithoutSizeIndicationUses0x42) {
  server({.respond_size_indicated = false});
  exchange({0x40, 0x01, 0x10, 0x00, 0, 0, 0, 0}, {0x42, 0x01, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00});
  exchange({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}, {0x42, 0x00, 0x10, 0x00, 0x96, 0x01, 0x01, 0x00});
}

// J§1.6.1 / E§7.1: 0x22 "parameter to encoder" without size; the object's
// size decides how many of the four bytes count.
TEST_F(SdoServerTest, E_7_1_DownloadWithoutSizeIndicationTakesObjectSize) {
  server();
  exchange({0x22, 0x00, 0x60, 0x00, 0x04, 0x00, 0xAA, 0xBB}, {0x60, 0x00, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00});
  EXPECT_EQ(od_.get_u16(0x6000, 0), 0x0004);
  exchange({0x22, 0x03, 0x60, 0x00, 0x01, 0x02, 0x03, 0x04}, {0x60, 0x03, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00});
  EXPECT_EQ(od_.get_u32(0x6003, 0), 0x04030201U);
}

// --- abort frames (J§1.6.3, E§7.3; CiA 301 §7.2.4.3.17) -------------------------

TEST_F(SdoServerTest, J_1_6_3_ObjectDoesNotExist) {
  server();
  exchange({0x40, 0x00, 0x30, 0x00, 0, 0, 0, 0}, {0x80, 0x00, 0x30, 0x00, 0x00, 0x00, 0x02, 0x06});
  exchange({0x23, 0x00, 0x30, 0x00, 1, 2, 3, 4}, {0x80, 0x00, 0x30, 0x00, 0x00, 0x00, 0x02, 0x06});
}

TEST_F(SdoServerTest, J_1_6_3_SubIndexDoesNotExist) {
  server();
  exchange({0x40, 0x18, 0x10, 0x05, 0, 0, 0, 0}, {0x80, 0x18, 0x10, 0x05, 0x11, 0x00, 0x09, 0x06});
}

TEST_F(SdoServerTest, J_1_6_3_WriteOfReadOnlyObject) {
  server();
  exchange({0x23, 0x00, 0x10, 0x00, 1, 2, 3, 4}, {0x80, 0x00, 0x10, 0x00, 0x02, 0x00, 0x01, 0x06});  // const
  exchange({0x23, 0x20, 0x60, 0x01, 1, 2, 3, 4}, {0x80, 0x20, 0x60, 0x01, 0x02, 0x00, 0x01, 0x06});  // ro
}

// E§4.3 0x2100 is write-only ("W"); reading it is refused.
TEST_F(SdoServerTest, E_7_3_ReadOfWriteOnlyObject) {
  server();
  exchange({0x40, 0x00, 0x21, 0x00, 0, 0, 0, 0}, {0x80, 0x00, 0x21, 0x00, 0x01, 0x00, 0x01, 0x06});
}

// J§1.3.3 0x2000 range 1..127 → 0x06090030 "value exceeded" (J§1.6.3).
TEST_F(SdoServerTest, J_1_6_3_ValueExceeded) {
  server();
  exchange({0x2F, 0x00, 0x20, 0x00, 0x80, 0, 0, 0}, {0x80, 0x00, 0x20, 0x00, 0x30, 0x00, 0x09, 0x06});
  EXPECT_EQ(od_.get_u8(0x2000, 0), 0x7F);
}

// J§1.4.2: 0x6001 writable only with scaling on; the device model's hook
// answers 0x08000022 "wrong state" (J§1.6.3).
TEST_F(SdoServerTest, J_1_4_2_HookVetoWrongState) {
  ASSERT_FALSE(od_.set_hooks(0x6001, 0, Hooks{.on_read = nullptr,
                                              .on_write = [this](const WriteRequest&) -> uint32_t {
                                                return (od_.get_u16(0x6000, 0).value_or(0) & 0x04U) ? 0U
                                                                                                    : 0x08000022U;
                                              },
                                              .after_write = nullptr}));
  server();
  exchange({0x23, 0x01, 0x60, 0x00, 0x00, 0x10, 0, 0}, {0x80, 0x01, 0x60, 0x00, 0x22, 0x00, 0x00, 0x08});
  EXPECT_EQ(od_.get_u32(0x6001, 0), 0x4000U);
  exchange({0x2B, 0x00, 0x60, 0x00, 0x04, 0x00, 0, 0}, {0x60, 0x00, 0x60, 0x00, 0, 0, 0, 0});
  exchange({0x23, 0x01, 0x60, 0x00, 0x00, 0x10, 0, 0}, {0x60, 0x01, 0x60, 0x00, 0, 0, 0, 0});
  EXPECT_EQ(od_.get_u32(0x6001, 0), 0x1000U);
}

// CiA 301 §7.2.4.3.17: 0x06070012 length too high / 0x06070013 too low.
TEST_F(SdoServerTest, CiA301_7_2_4_3_17_LengthMismatch) {
  server();
  // 4 bytes to the UNSIGNED16 0x6000.
  exchange({0x23, 0x00, 0x60, 0x00, 1, 0, 0, 0}, {0x80, 0x00, 0x60, 0x00, 0x12, 0x00, 0x07, 0x06});
  // 1 byte to the UNSIGNED32 0x6003.
  exchange({0x2F, 0x03, 0x60, 0x00, 1, 0, 0, 0}, {0x80, 0x03, 0x60, 0x00, 0x13, 0x00, 0x07, 0x06});
}

// The manuals list no length code (J§1.6.3, E§7.3); their general code
// 0x08000000 is available through the override.
TEST_F(SdoServerTest, J_1_6_3_LengthMismatchOverriddenToGeneralError) {
  server({.length_abort_override = 0x08000000});
  exchange({0x23, 0x00, 0x60, 0x00, 1, 0, 0, 0}, {0x80, 0x00, 0x60, 0x00, 0x00, 0x00, 0x00, 0x08});
  // Other codes are not affected.
  exchange({0x2F, 0x00, 0x20, 0x00, 0x80, 0, 0, 0}, {0x80, 0x00, 0x20, 0x00, 0x30, 0x00, 0x09, 0x06});
}

// --- segmented upload (CiA 301 §7.2.4.3.6, §7.2.4.3.7) ---------------------------

// J§1.3.1 0x1008 "RFC-4801-214-614-511" (20 bytes) byte for byte: initiate
// with size, then segments with alternating toggle; the last carries 6 bytes
// (n = 1) and c = 1.
TEST_F(SdoServerTest, CiA301_7_2_4_3_7_SegmentedUploadOfDeviceName) {
  auto& s = server();
  exchange({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}, {0x41, 0x08, 0x10, 0x00, 0x14, 0x00, 0x00, 0x00});
  EXPECT_TRUE(s.transfer_open());
  exchange({0x60, 0, 0, 0, 0, 0, 0, 0}, {0x00, 'R', 'F', 'C', '-', '4', '8', '0'});
  exchange({0x70, 0, 0, 0, 0, 0, 0, 0}, {0x10, '1', '-', '2', '1', '4', '-', '6'});
  exchange({0x60, 0, 0, 0, 0, 0, 0, 0}, {0x03, '1', '4', '-', '5', '1', '1', 0x00});
  EXPECT_FALSE(s.transfer_open());
  EXPECT_EQ(s.process(t0), kNever);
}

// CiA 301 §7.2.4.3.6: without size indication the initiate response is 0x40.
TEST_F(SdoServerTest, CiA301_7_2_4_3_6_SegmentedUploadWithoutSize) {
  server({.respond_size_indicated = false});
  exchange({0x40, 0x09, 0x10, 0x00, 0, 0, 0, 0}, {0x40, 0x09, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00});
  // "V 1.00" is 6 bytes: one segment, n = 1, c = 1.
  exchange({0x60, 0, 0, 0, 0, 0, 0, 0}, {0x03, 'V', ' ', '1', '.', '0', '0', 0x00});
}

// An empty string cannot be sent expedited: size 0, then one empty last
// segment (n = 7, c = 1).
TEST_F(SdoServerTest, CiA301_7_2_4_3_7_EmptyStringUploadedSegmented) {
  server();
  exchange({0x40, 0x00, 0x2F, 0x00, 0, 0, 0, 0}, {0x41, 0x00, 0x2F, 0x00, 0x00, 0x00, 0x00, 0x00});
  exchange({0x60, 0, 0, 0, 0, 0, 0, 0}, {0x0F, 0, 0, 0, 0, 0, 0, 0});
}

// CiA 301 §7.2.4.3.17: 0x05030000 toggle bit not alternated.
TEST_F(SdoServerTest, CiA301_7_2_4_3_7_UploadToggleError) {
  auto& s = server();
  exchange({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}, {0x41, 0x08, 0x10, 0x00, 0x14, 0x00, 0x00, 0x00});
  exchange({0x60, 0, 0, 0, 0, 0, 0, 0}, {0x00, 'R', 'F', 'C', '-', '4', '8', '0'});
  exchange({0x60, 0, 0, 0, 0, 0, 0, 0}, {0x80, 0x08, 0x10, 0x00, 0x00, 0x00, 0x03, 0x05});
  EXPECT_FALSE(s.transfer_open());
}

// J§1.2.4 / E§3.2 "segmented transfer: No": with segmented off a long
// object is refused with the configured abort (default 0x08000000, which
// the manuals list; 0x06010000 as an alternative).
TEST_F(SdoServerTest, E_3_2_SegmentedOffRefusesLongUpload) {
  server({.segmented = false});
  exchange({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}, {0x80, 0x08, 0x10, 0x00, 0x00, 0x00, 0x00, 0x08});
  exchange({0x21, 0x00, 0x2F, 0x00, 0x05, 0, 0, 0}, {0x80, 0x00, 0x2F, 0x00, 0x00, 0x00, 0x00, 0x08});
  // Expedited still works.
  exchange({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}, {0x43, 0x00, 0x10, 0x00, 0x96, 0x01, 0x01, 0x00});
  server({.segmented = false, .segmented_disabled_abort = 0x06010000});
  exchange({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}, {0x80, 0x08, 0x10, 0x00, 0x00, 0x00, 0x01, 0x06});
}

// --- segmented download (CiA 301 §7.2.4.3.3, §7.2.4.3.4) --------------------------

TEST_F(SdoServerTest, CiA301_7_2_4_3_4_SegmentedDownloadWithSize) {
  auto& s = server();
  exchange({0x21, 0x00, 0x2F, 0x00, 0x0A, 0x00, 0x00, 0x00}, {0x60, 0x00, 0x2F, 0x00, 0, 0, 0, 0});
  exchange({0x00, 'c', 'o', 'b', 'r', 'i', 'd', 'g'}, {0x20, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(od_.get_string(0x2F00, 0), "");  // nothing stored before the last segment
  // Last: t = 1, 3 bytes (n = 4), c = 1 → 0x10 | 0x08 | 0x01.
  exchange({0x19, 'e', '-', '1', 0, 0, 0, 0}, {0x30, 0, 0, 0, 0, 0, 0, 0});
  EXPECT_EQ(od_.get_string(0x2F00, 0), "cobridge-1");
  EXPECT_FALSE(s.transfer_open());
}

TEST_F(SdoServerTest, CiA301_7_2_4_3_3_SegmentedDownloadWithoutSize) {
  server();
  exchange({0x20, 0x00, 0x2F, 0x00, 0, 0, 0, 0}, {0x60, 0x00, 0x2F, 0x00, 0, 0, 0, 0});
  exchange({0x0B, 'a', 'b', 0, 0, 0, 0, 0}, {0x20, 0, 0, 0, 0, 0, 0, 0});  // n = 5, c = 1
  EXPECT_EQ(od_.get_string(0x2F00, 0), "ab");
}

// A 4-byte number may also be written segmented (CiA 301 leaves the choice
// to the client); the dictionary's checks apply at the end.
TEST_F(SdoServerTest, CiA301_7_2_4_3_4_SegmentedDownloadOfNumberCheckedAtEnd) {
  server();
  exchange({0x21, 0x00, 0x20, 0x00, 0x01, 0, 0, 0}, {0x60, 0x00, 0x20, 0x00, 0, 0, 0, 0});
  exchange({0x0D, 0x80, 0, 0, 0, 0, 0, 0}, {0x80, 0x00, 0x20, 0x00, 0x30, 0x00, 0x09, 0x06});  // 128 out of range
  EXPECT_EQ(od_.get_u8(0x2000, 0), 0x7F);
}

TEST_F(SdoServerTest, CiA301_7_2_4_3_4_DownloadToggleError) {
  server();
  exchange({0x21, 0x00, 0x2F, 0x00, 0x0A, 0, 0, 0}, {0x60, 0x00, 0x2F, 0x00, 0, 0, 0, 0});
  exchange({0x10, 'c', 'o', 'b', 'r', 'i', 'd', 'g'}, {0x80, 0x00, 0x2F, 0x00, 0x00, 0x00, 0x03, 0x05});
  EXPECT_EQ(od_.get_string(0x2F00, 0), "");
}

// Announced size above the object's capacity is refused at initiate; data
// that disagrees with the announced size gets 0x06070010.
TEST_F(SdoServerTest, CiA301_7_2_4_3_17_SegmentedDownloadSizeChecks) {
  server();
  exchange({0x21, 0x00, 0x2F, 0x00, 0x11, 0, 0, 0}, {0x80, 0x00, 0x2F, 0x00, 0x12, 0x00, 0x07, 0x06});
  exchange({0x21, 0x00, 0x2F, 0x00, 0x0A, 0, 0, 0}, {0x60, 0x00, 0x2F, 0x00, 0, 0, 0, 0});
  exchange({0x01, 'a', 'b', 'c', 'd', 'e', 'f', 'g'}, {0x80, 0x00, 0x2F, 0x00, 0x10, 0x00, 0x07, 0x06});
  exchange({0x21, 0x00, 0x2F, 0x00, 0x04, 0, 0, 0}, {0x60, 0x00, 0x2F, 0x00, 0, 0, 0, 0});
  exchange({0x00, 'a', 'b', 'c', 'd', 'e', 'f', 'g'}, {0x80, 0x00, 0x2F, 0x00, 0x10, 0x00, 0x07, 0x06});
  // Writes to read-only objects are refused at initiate.
  exchange({0x21, 0x08, 0x10, 0x00, 0x04, 0, 0, 0}, {0x80, 0x08, 0x10, 0x00, 0x02, 0x00, 0x01, 0x06});
}

// --- protocol errors ---------------------------------------------------------------

// CiA 301 §7.2.4.3.17: 0x05040000 SDO protocol timed out. The deadline moves
// with every segment.
TEST_F(SdoServerTest, CiA301_7_2_4_3_17_SegmentTimeout) {
  auto& s = server({.segment_timeout = 500ms});
  EXPECT_EQ(s.process(t0), kNever);
  exchange({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}, {0x41, 0x08, 0x10, 0x00, 0x14, 0x00, 0x00, 0x00});
  EXPECT_EQ(s.process(t0 + 100ms), t0 + 500ms);
  exchange({0x60, 0, 0, 0, 0, 0, 0, 0}, {0x00, 'R', 'F', 'C', '-', '4', '8', '0'}, t0 + 400ms);
  sink_.frames.clear();
  EXPECT_EQ(s.process(t0 + 899ms), t0 + 900ms);
  EXPECT_TRUE(sink_.frames.empty());
  EXPECT_EQ(s.process(t0 + 900ms), kNever);
  ASSERT_EQ(sink_.frames.size(), 1U);
  EXPECT_EQ(sink_.frames[0],
            can::Frame::make8(cob::kSdoTxBase + kNode, {0x80, 0x08, 0x10, 0x00, 0x00, 0x00, 0x04, 0x05}));
  EXPECT_FALSE(s.transfer_open());
  // A late segment request now has no transfer: 0x05040001, multiplexer 0.
  exchange({0x70, 0, 0, 0, 0, 0, 0, 0}, {0x80, 0x00, 0x00, 0x00, 0x01, 0x00, 0x04, 0x05}, t0 + 1s);
}

// J§1.2.4 / E§3.2 "block transfer: No" → CiA 301 0x05040001.
TEST_F(SdoServerTest, E_3_2_BlockTransferRejected) {
  server();
  exchange({0xA0, 0x08, 0x10, 0x00, 0x7F, 0, 0, 0}, {0x80, 0x08, 0x10, 0x00, 0x01, 0x00, 0x04, 0x05});
  exchange({0xC2, 0x00, 0x2F, 0x00, 0x0A, 0, 0, 0}, {0x80, 0x00, 0x2F, 0x00, 0x01, 0x00, 0x04, 0x05});
  exchange({0xE0, 0x00, 0x10, 0x00, 0, 0, 0, 0}, {0x80, 0x00, 0x10, 0x00, 0x01, 0x00, 0x04, 0x05});
}

// A segment of the wrong direction aborts the open transfer with its
// multiplexer.
TEST_F(SdoServerTest, CiA301_7_2_4_3_17_WrongDirectionSegmentAborts) {
  auto& s = server();
  exchange({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}, {0x41, 0x08, 0x10, 0x00, 0x14, 0x00, 0x00, 0x00});
  exchange({0x00, 1, 2, 3, 4, 5, 6, 7}, {0x80, 0x08, 0x10, 0x00, 0x01, 0x00, 0x04, 0x05});
  EXPECT_FALSE(s.transfer_open());
}

// CiA 301 §7.2.4.3.17: a client abort ends the transfer; the server does
// not answer it.
TEST_F(SdoServerTest, CiA301_7_2_4_3_17_ClientAbortClosesTransferSilently) {
  auto& s = server();
  exchange({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}, {0x41, 0x08, 0x10, 0x00, 0x14, 0x00, 0x00, 0x00});
  EXPECT_TRUE(request({0x80, 0x08, 0x10, 0x00, 0x00, 0x00, 0x04, 0x05}).empty());
  EXPECT_FALSE(s.transfer_open());
  EXPECT_EQ(s.process(t0 + 1h), kNever);
  EXPECT_TRUE(sink_.frames.empty());
}

// A new initiate while a transfer is open replaces it.
TEST_F(SdoServerTest, CiA301_7_2_4_3_6_NewInitiateReplacesOpenTransfer) {
  server();
  exchange({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}, {0x41, 0x08, 0x10, 0x00, 0x14, 0x00, 0x00, 0x00});
  exchange({0x60, 0, 0, 0, 0, 0, 0, 0}, {0x00, 'R', 'F', 'C', '-', '4', '8', '0'});
  exchange({0x40, 0x09, 0x10, 0x00, 0, 0, 0, 0}, {0x41, 0x09, 0x10, 0x00, 0x06, 0x00, 0x00, 0x00});
  exchange({0x60, 0, 0, 0, 0, 0, 0, 0}, {0x03, 'V', ' ', '1', '.', '0', '0', 0x00});
}

// --- frame filtering and switches ----------------------------------------------------

// CiA 301 §7.2.4.3: SDO frames have 8 data bytes; others are ignored.
TEST_F(SdoServerTest, CiA301_7_2_4_3_ShortFrameIgnored) {
  auto& s = server();
  sink_.frames.clear();
  EXPECT_TRUE(s.on_frame(can::Frame::make(cob::kSdoRxBase + kNode, {0x40, 0x00, 0x10, 0x00}), t0));
  EXPECT_TRUE(sink_.frames.empty());
}

TEST_F(SdoServerTest, OtherFramesNotConsumed) {
  auto& s = server();
  sink_.frames.clear();
  const Bytes8 upload{0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0};
  EXPECT_FALSE(s.on_frame(can::Frame::make8(cob::kSdoRxBase + 1, upload), t0));   // other node
  EXPECT_FALSE(s.on_frame(can::Frame::make8(cob::kSdoTxBase + kNode, upload), t0));  // a response
  auto rtr = can::Frame::make8(cob::kSdoRxBase + kNode, upload);
  rtr.flags = can::Frame::kFlagRtr;
  EXPECT_FALSE(s.on_frame(rtr, t0));
  auto ext = can::Frame::make8(cob::kSdoRxBase + kNode, upload);
  ext.flags = can::Frame::kFlagExtended;
  EXPECT_FALSE(s.on_frame(ext, t0));
  EXPECT_TRUE(sink_.frames.empty());
}

// J§1.2.2: COB-IDs follow the node-ID (0x600/0x580 + node).
TEST_F(SdoServerTest, J_1_2_2_NodeIdChangeMovesCobIds) {
  auto& s = server();
  s.set_node_id(5);
  EXPECT_EQ(s.node_id(), 5);
  sink_.frames.clear();
  EXPECT_FALSE(s.on_frame(can::Frame::make8(cob::kSdoRxBase + kNode, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}), t0));
  exchange({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}, {0x43, 0x00, 0x10, 0x00, 0x96, 0x01, 0x01, 0x00}, t0, 5);
  EXPECT_EQ(sink_.frames[0].id, 0x585U);
}

// A silent server (simulated pulled cable) neither answers nor times out.
TEST_F(SdoServerTest, DisabledServerIsSilent) {
  auto& s = server();
  exchange({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}, {0x41, 0x08, 0x10, 0x00, 0x14, 0x00, 0x00, 0x00});
  s.set_enabled(false);
  sink_.frames.clear();
  EXPECT_FALSE(s.on_frame(can::Frame::make8(cob::kSdoRxBase + kNode, {0x60, 0, 0, 0, 0, 0, 0, 0}), t0));
  EXPECT_EQ(s.process(t0 + 1h), kNever);
  EXPECT_TRUE(sink_.frames.empty());
  s.set_enabled(true);
  EXPECT_FALSE(s.transfer_open());
  exchange({0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}, {0x43, 0x00, 0x10, 0x00, 0x96, 0x01, 0x01, 0x00});
}

TEST_F(SdoServerTest, RefusedSendIsCounted) {
  auto& s = server();
  sink_.accept = false;
  EXPECT_TRUE(s.on_frame(can::Frame::make8(cob::kSdoRxBase + kNode, {0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}), t0));
  EXPECT_EQ(s.tx_failures(), 1U);
}

// A buffer smaller than a value: the server answers 0x05040005 (out of memory).
TEST_F(SdoServerTest, CiA301_7_2_4_3_17_BufferTooSmallIsOutOfMemory) {
  server({.buffer_size = 8});
  exchange({0x40, 0x08, 0x10, 0x00, 0, 0, 0, 0}, {0x80, 0x08, 0x10, 0x00, 0x05, 0x00, 0x04, 0x05});
}

}  // namespace
}  // namespace cobridge::canopen
