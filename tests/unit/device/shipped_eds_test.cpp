// The EDS files shipped in config/devices: every one parses, and the values
// in them match the device manuals (J = Novotechnik rotary, F = ifm RM8/RM9,
// E = Novotechnik multiturn; sections as in /work/shared/seeds).
#include "device/device_catalog.hpp"
#include "device/eds.hpp"

#include "unit/device/source_paths.hpp"

#include <gtest/gtest.h>

#include <array>
#include <filesystem>
#include <string>

using namespace cobridge::device;
using cobridge::device::test::shipped_devices_dir;

namespace {

std::string dump(const std::vector<EdsError>& errors) {
  std::string s;
  for (const auto& e : errors) s += e.to_string() + "\n";
  return s;
}

DeviceDescription load(const std::string& name) {
  EdsResult r = load_eds_file(shipped_devices_dir() / name);
  EXPECT_TRUE(r.ok()) << dump(r.errors);
  return r.ok() ? std::move(*r.description) : DeviceDescription{};
}

std::optional<std::uint64_t> def(const DeviceDescription& d, std::uint16_t index, std::uint8_t sub,
                                 std::uint8_t node = 1) {
  const ObjectDesc* o = d.find(index, sub);
  if (o == nullptr) {
    ADD_FAILURE() << "object " << std::hex << index << " sub " << int{sub} << " missing in " << d.source;
    return std::nullopt;
  }
  return o->default_for_node(node);
}

struct RotarySeries {
  const char* file_stem;
  std::uint32_t product;
  bool legacy;  // RSX-7900 / RFX-6900 firmware (J§1.12 V10)
};
constexpr std::array<RotarySeries, 5> kRotary{{
    {"novotechnik-rfc4800", 0x0BE0, false},
    {"novotechnik-rsa3200", 0x0BF3, false},
    {"novotechnik-rfe3200", 0x0BBD, false},
    {"novotechnik-rsx7900", 0x0BCD, true},
    {"novotechnik-rfx6900", 0x0BE1, true},
}};

}  // namespace

TEST(ShippedEds, EveryFileInConfigDevicesParses) {
  std::size_t count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(shipped_devices_dir())) {
    if (entry.path().extension() != ".eds") continue;
    ++count;
    const EdsResult r = load_eds_file(entry.path());
    EXPECT_TRUE(r.ok()) << dump(r.errors);
  }
  EXPECT_EQ(count, 12U);  // 5 rotary series x 2 variants, ifm, multiturn
}

// J§1.2.1 identity, J§1.3.1 communication area, J§1.3.2 device area,
// J§1.3.3 manufacturer area, for all five series and both variants.
TEST(ShippedEds, RotaryValuesMatchManualJ_J1_2_1_J1_3_1_to_1_3_3) {
  for (const auto& series : kRotary) {
    for (const int ch : {1, 2}) {
      const std::string name = std::string(series.file_stem) + "-" + std::to_string(ch) + "ch.eds";
      SCOPED_TRACE(name);
      const DeviceDescription d = load(name);
      // J§1.2.1
      EXPECT_EQ(d.device_info.vendor_number, 0x182U);
      EXPECT_EQ(d.device_info.product_number, series.product);
      EXPECT_EQ(def(d, 0x1018, 1), 0x182U);
      EXPECT_EQ(def(d, 0x1018, 2), series.product);
      // J§1.3.1
      EXPECT_EQ(def(d, 0x1000, 0), 0x00010196U);
      EXPECT_EQ(d.find(0x1000, 0)->access, AccessType::kConst);
      EXPECT_EQ(d.find(0x1001, 0)->data_type, DataType::kUnsigned8);
      EXPECT_EQ(def(d, 0x1005, 0), 0x80U);
      EXPECT_EQ(def(d, 0x1014, 0, 5), 0x85U);  // 0x80 + node-ID
      EXPECT_EQ(d.find(0x1014, 0)->access, AccessType::kRo);
      EXPECT_EQ(def(d, 0x1800, 1, 5), 0x40000185U);  // 0x40000180 + node-ID, RTR not allowed
      EXPECT_EQ(def(d, 0x1800, 2), 254U);
      EXPECT_EQ(def(d, 0x1800, 5), 0U);  // event timer disabled
      EXPECT_EQ(def(d, 0x1801, 1, 5), 0x40000285U);
      EXPECT_EQ(def(d, 0x1801, 2), 1U);
      EXPECT_EQ(def(d, 0x1A00, 1), 0x60200120U);
      EXPECT_EQ(def(d, 0x1A00, 2), ch == 1 ? 0x60300110U : 0x60200220U);
      EXPECT_EQ(def(d, 0x1F80, 0), 0U);
      // Store sub-indices: 1..5, or 1..4 on RSX/RFX (J§1.3.1, J§1.10; errata A.9.21).
      EXPECT_EQ(def(d, 0x1010, 0), series.legacy ? 4U : 5U);
      EXPECT_EQ(d.find(0x1010, 5) != nullptr, !series.legacy);
      // J§1.3.2
      EXPECT_EQ(d.find(0x6000, 0)->data_type, DataType::kUnsigned16);
      EXPECT_EQ(def(d, 0x6001, 0), 0x4000U);
      EXPECT_EQ(def(d, 0x6002, 0), 0x4000U);
      for (const int i : {0x6010, 0x6020, 0x6030, 0x6300, 0x6400, 0x6401, 0x6402}) {
        const auto idx = static_cast<std::uint16_t>(i);
        EXPECT_EQ(def(d, idx, 0), static_cast<std::uint64_t>(ch)) << std::hex << idx;
        EXPECT_EQ(d.find(idx, 2) != nullptr, ch == 2) << std::hex << idx;
      }
      const ObjectDesc* pos = d.find(0x6020, 1);
      ASSERT_NE(pos, nullptr);
      EXPECT_EQ(pos->data_type, DataType::kInteger32);
      EXPECT_EQ(pos->access, AccessType::kRo);
      EXPECT_TRUE(pos->pdo_mapping);
      EXPECT_EQ(d.find(0x6030, 1)->data_type, DataType::kInteger16);
      EXPECT_EQ(def(d, 0x6320, 1), 0x3FFFU);
      EXPECT_EQ(def(d, 0x6402, 1), 0x3FFFU);
      // Errata A.9.5: 0x6323 typed like its siblings, not INTEGER8/UNSIGNED32.
      EXPECT_EQ(d.find(0x6323, 0)->data_type, DataType::kUnsigned8);
      EXPECT_EQ(d.find(0x6323, 1)->data_type, DataType::kInteger32);
      EXPECT_EQ(d.find(0x6330, 1)->data_type, DataType::kInteger16);
      EXPECT_EQ(def(d, 0x6501, 0), 0x4000U);
      EXPECT_EQ(def(d, 0x6502, 0), 1U);
      EXPECT_EQ(def(d, 0x6504, 0), 0x1001U);
      EXPECT_EQ(def(d, 0x6506, 0), 0x1000U);
      // J§1.3.3: node-ID 0x2000 default 127, range 1..127; bit rate 0x2001 in kbit/s.
      EXPECT_EQ(def(d, 0x2000, 0), 127U);
      EXPECT_EQ(d.find(0x2000, 0)->low_limit.integer, 1U);
      EXPECT_EQ(d.find(0x2000, 0)->high_limit.integer, 127U);
      EXPECT_EQ(d.find(0x2001, 0)->data_type, DataType::kUnsigned16);
      // Variant selection data.
      EXPECT_EQ(d.selection.variant, std::to_string(ch) + "ch");
      EXPECT_EQ(d.selection.probe_index, 0x6020);
      EXPECT_EQ(d.selection.probe_sub, 0);
      EXPECT_EQ(d.selection.probe_value, static_cast<std::uint64_t>(ch));
    }
  }
}

// F§7.3 communication area, F§7.4 manufacturer area, F§7.5 device area,
// F§5.3.1/5.3.2 default address and bit rate.
TEST(ShippedEds, IfmValuesMatchManualF_F7_3_to_7_5) {
  const DeviceDescription d = load("ifm-rm8-rm9.eds");
  EXPECT_EQ(d.device_info.vendor_number, 0x0069666DU);
  EXPECT_EQ(def(d, 0x1018, 1), 0x0069666DU);
  EXPECT_EQ(def(d, 0x1018, 3), 0x00010000U);
  EXPECT_TRUE(d.selection.match_any_product);  // errata B.9.3: product code "0x43 0x41"
  // F§7.4 0x3000: node-ID = value + 1; F§5.3.1 default address 32.
  EXPECT_EQ(def(d, 0x3000, 0), 31U);
  EXPECT_EQ(def(d, 0x3000, 0).value_or(0) + 1, 32U);
  // F§7.4 0x3001: 3 = 125 kbit/s (F§5.3.2), eight rates 0..7.
  EXPECT_EQ(def(d, 0x3001, 0), 3U);
  EXPECT_EQ(d.find(0x3001, 0)->high_limit.integer, 7U);
  EXPECT_TRUE(d.device_info.baud_125);
  EXPECT_TRUE(d.device_info.baud_20);
  EXPECT_FALSE(d.device_info.baud_10);
  // F§7.3
  EXPECT_EQ(def(d, 0x1014, 0, 32), 0xA0U);
  EXPECT_EQ(d.find(0x1014, 0)->access, AccessType::kRw);
  EXPECT_EQ(def(d, 0x1800, 1, 32), 0x1A0U);  // RTR allowed (bit 30 clear)
  EXPECT_EQ(def(d, 0x1800, 2), 0xFEU);
  EXPECT_EQ(def(d, 0x1800, 5), 0x64U);
  EXPECT_EQ(d.find(0x1800, 4), nullptr);  // "non disponible"
  EXPECT_EQ(d.find(0x1800, 3)->data_type, DataType::kUnsigned32);  // as printed (errata B.9.5)
  EXPECT_EQ(def(d, 0x1801, 1, 32), 0x2A0U);
  EXPECT_EQ(def(d, 0x1010, 0), 1U);
  EXPECT_EQ(def(d, 0x1018, 0), 4U);  // printed 1 (errata B.9.3)
  EXPECT_EQ(def(d, 0x1003, 0), 0U);
  EXPECT_NE(d.find(0x1003, 10), nullptr);
  // F§7.4
  EXPECT_EQ(def(d, 0x2102, 0), 0x1000000U);
  EXPECT_EQ(d.find(0x2300, 0)->access, AccessType::kWo);
  EXPECT_EQ(def(d, 0x2300, 0), 0x55AAAA55U);
  EXPECT_EQ(def(d, 0x3010, 0), 2U);
  // F§7.5
  EXPECT_EQ(def(d, 0x6000, 0), 1U);
  EXPECT_EQ(d.find(0x6004, 0)->data_type, DataType::kUnsigned32);
  EXPECT_TRUE(d.find(0x6004, 0)->pdo_mapping);
  EXPECT_EQ(def(d, 0x6200, 0), 0x64U);
  for (std::uint16_t cam = 0; cam < 8; ++cam) {
    EXPECT_NE(d.find(static_cast<std::uint16_t>(0x6310 + cam), 1), nullptr);
    EXPECT_EQ(d.find(static_cast<std::uint16_t>(0x6330 + cam), 1)->data_type, DataType::kUnsigned32);
  }
  EXPECT_EQ(d.find(0x6401, 0)->data_type, DataType::kUnsigned8);  // printed integer32 (errata B.9.14)
  EXPECT_EQ(d.find(0x6401, 1)->data_type, DataType::kInteger32);
}

// E§4.1 communication area, E§4.2 device area, E§4.3 manufacturer area with
// condition monitoring, E§13 V03 product codes.
TEST(ShippedEds, MultiturnValuesMatchManualE_E4_1_to_4_3) {
  const DeviceDescription d = load("novotechnik-multiturn.eds");
  // E§4.1
  EXPECT_EQ(def(d, 0x1000, 0), 0x00020196U);
  EXPECT_EQ(def(d, 0x1018, 1), 0x182U);
  EXPECT_EQ(def(d, 0x1018, 2), 0x0BB8U);
  EXPECT_EQ(d.selection.additional_products, (std::vector<std::uint32_t>{0x0BD5, 0x0BB9, 0x0BBC}));
  EXPECT_EQ(d.find(0x1001, 0)->data_type, DataType::kUnsigned8);   // printed Unsigned16 (C.9.1)
  EXPECT_EQ(d.find(0x1002, 0)->data_type, DataType::kUnsigned32);  // printed Unsigned16 (C.9.1)
  EXPECT_EQ(def(d, 0x1029, 0), 2U);
  EXPECT_EQ(def(d, 0x1800, 1, 0x7F), 0x400001FFU);
  EXPECT_EQ(def(d, 0x1A00, 2), 0x60300110U);
  EXPECT_EQ(def(d, 0x1010, 0), 5U);
  // E§4.2
  EXPECT_EQ(def(d, 0x6001, 0), 0x10000U);
  EXPECT_EQ(def(d, 0x6002, 0), 0x2C0000U);
  EXPECT_EQ(d.find(0x6000, 0)->data_type, DataType::kUnsigned8);  // as printed (C.9.2)
  const ObjectDesc* pos = d.find(0x6004, 0);
  ASSERT_NE(pos, nullptr);
  EXPECT_EQ(pos->data_type, DataType::kInteger32);
  EXPECT_TRUE(pos->pdo_mapping);
  EXPECT_TRUE(d.find(0x600C, 0)->pdo_mapping);
  EXPECT_EQ(def(d, 0x6031, 1), 2U);
  EXPECT_EQ(def(d, 0x6320, 1), 0x2BFFFFU);
  EXPECT_EQ(d.find(0x6330, 1)->data_type, DataType::kUnsigned16);
  EXPECT_EQ(def(d, 0x6502, 0), 44U);
  EXPECT_EQ(def(d, 0x6504, 0), 0xC002U);
  EXPECT_EQ(def(d, 0x6506, 0), 0xC05CU);
  EXPECT_EQ(def(d, 0x650A, 3), 0x2BFFFFU);
  EXPECT_EQ(def(d, 0x650E, 0), 3U);
  // E§4.3
  EXPECT_EQ(def(d, 0x2000, 0), 127U);
  EXPECT_EQ(d.find(0x2002, 0)->data_type, DataType::kInteger16);
  EXPECT_TRUE(d.find(0x2002, 0)->pdo_mapping);
  EXPECT_TRUE(d.find(0x2003, 0)->pdo_mapping);
  EXPECT_EQ(def(d, 0x2010, 2), 3U);
  EXPECT_EQ(d.find(0x2100, 0)->data_type, DataType::kBoolean);
  EXPECT_EQ(d.find(0x2100, 0)->access, AccessType::kWo);
  EXPECT_EQ(def(d, 0x2300, 0), 6U);
  EXPECT_EQ(def(d, 0x230A, 0), 0xFFFFU);
  EXPECT_EQ(def(d, 0x232A, 0), 6U);
  EXPECT_TRUE(d.find(0x2330, 2)->pdo_mapping);
  EXPECT_EQ(def(d, 0x2350, 0), 9U);
  EXPECT_EQ(d.find(0x2350, 9)->data_type, DataType::kInteger16);
  EXPECT_EQ(def(d, 0x2360, 0), 9U);
  EXPECT_EQ(d.find(0x236B, 2)->access, AccessType::kRo);
  EXPECT_EQ(d.find(0x235A, 1)->access, AccessType::kRw);
}

// Identity selection over the shipped files (J§1.2.1, E§4.1/E§13, F§7.3).
TEST(ShippedEds, CatalogSelectsByVendorProductAndVariant_J1_2_1_E13_F7_3) {
  DeviceCatalog catalog;
  const auto errors = catalog.load_directory(shipped_devices_dir());
  EXPECT_TRUE(errors.empty()) << dump(errors);
  EXPECT_EQ(catalog.size(), 12U);

  for (const auto& series : kRotary) {
    for (const int ch : {1, 2}) {
      const DeviceDescription* d = catalog.select(0x182, series.product, 0x00010003, std::to_string(ch) + "ch");
      ASSERT_NE(d, nullptr) << series.file_stem;
      EXPECT_EQ(std::filesystem::path(d->source).filename().string(),
                std::string(series.file_stem) + "-" + std::to_string(ch) + "ch.eds");
    }
    // Without the variant the rotary product is ambiguous; the candidates
    // carry the probe (0x6020 sub 0 = number of channels) to resolve it.
    EXPECT_EQ(catalog.select(0x182, series.product), nullptr);
    const auto cands = catalog.candidates(0x182, series.product);
    ASSERT_EQ(cands.size(), 2U);
    for (const auto* c : cands) {
      EXPECT_EQ(c->selection.probe_index, 0x6020);
      EXPECT_EQ(catalog.select(0x182, series.product, std::nullopt, c->selection.variant), c);
    }
  }

  const DeviceDescription* multiturn = catalog.select(0x182, 0x0BB8);
  ASSERT_NE(multiturn, nullptr);
  EXPECT_EQ(std::filesystem::path(multiturn->source).filename(), "novotechnik-multiturn.eds");
  for (const std::uint32_t legacy : {0x0BD5U, 0x0BB9U, 0x0BBCU}) {
    EXPECT_EQ(catalog.select(0x182, legacy), multiturn) << std::hex << legacy;
  }

  const DeviceDescription* ifm = catalog.select(0x0069666D, 0x4341);
  ASSERT_NE(ifm, nullptr);
  EXPECT_EQ(std::filesystem::path(ifm->source).filename(), "ifm-rm8-rm9.eds");
  EXPECT_EQ(catalog.select(0x0069666D, 0x4143), ifm);  // other byte order of "0x43 0x41"
  EXPECT_EQ(catalog.select(0x0069666D, 0x12345), ifm);

  EXPECT_EQ(catalog.select(0x182, 0x9999), nullptr);
  EXPECT_EQ(catalog.select(0x999, 0x0BE0, std::nullopt, "1ch"), nullptr);
}
