// The device families' facts (daemon/families), checked against the
// manuals they cite: J = Novotechnik rotary, E = Novotechnik multiturn,
// F = ifm RM8/RM9 (J§1.2.1, F§7.3, E§4.1).
#include "families/family.hpp"
#include "families/ifm_rm.hpp"
#include "families/novotechnik.hpp"
#include "families/novotechnik_multiturn.hpp"
#include "families/novotechnik_rotary.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <set>
#include <string>

using namespace cobridge::families;

namespace {
std::filesystem::path devices_dir() {
  // tests/unit/families/family_test.cpp -> repository root
  return std::filesystem::path(__FILE__).parent_path().parent_path().parent_path().parent_path() /
         "config" / "devices";
}
}  // namespace

TEST(Families, RegistryListsEachFamilyOnceUnderItsEdsName) {
  std::set<std::string_view> names;
  for (const Family* f : all()) {
    EXPECT_TRUE(names.insert(f->name).second) << f->name;
    EXPECT_EQ(find_family(f->name), f);
    EXPECT_FALSE(f->models.empty()) << f->name;
  }
  EXPECT_EQ(names, (std::set<std::string_view>{"novotechnik-rotary", "novotechnik-multiturn", "ifm-rm"}));
  EXPECT_EQ(find_family("generic"), nullptr);
}

// The one identity: each FamilyId names exactly its own module.
TEST(Families, EachIdNamesItsModule) {
  EXPECT_EQ(&family(FamilyId::novotechnik_rotary), &kNovotechnikRotary);
  EXPECT_EQ(&family(FamilyId::novotechnik_multiturn), &kNovotechnikMultiturn);
  EXPECT_EQ(&family(FamilyId::ifm_rm), &kIfmRm);
  for (const Family* f : all()) EXPECT_EQ(&family(f->id), f) << f->name;
}

// J§1.2.1: vendor 0x182 and one product code per series.
TEST(Families, RotaryIdentityIsJ121) {
  EXPECT_EQ(kNovotechnikRotary.vendor, 0x00000182U);
  EXPECT_EQ(family_of(0x182, 0x0BE0), &kNovotechnikRotary);
  EXPECT_EQ(family_of(0x182, 0x0BCD), &kNovotechnikRotary);
  EXPECT_EQ(family_of(0x182, 0x1234), nullptr);
  EXPECT_TRUE(is_legacy_rsx_rfx(0x0BCD));
  EXPECT_TRUE(is_legacy_rsx_rfx(0x0BE1));
  EXPECT_FALSE(is_legacy_rsx_rfx(0x0BE0));
  // J§1 intro: DSP-305 V1.1.2, no Fastscan.
  EXPECT_FALSE(kNovotechnikRotary.lss_fastscan);
}

// E§4.1 and E§13 V03: 0x0BB8 since V03, the older per-model codes before.
TEST(Families, MultiturnAcceptsBothProductCodeGenerations) {
  for (const std::uint32_t p : {0x0BB8U, 0x0BD5U, 0x0BB9U, 0x0BBCU}) EXPECT_EQ(family_of(0x182, p), &kNovotechnikMultiturn);
  const ModelRef mc = find_model("MC1-2800");
  ASSERT_NE(mc.model, nullptr);
  EXPECT_EQ(mc.family, &kNovotechnikMultiturn);
  ASSERT_EQ(mc.model->products.size(), 2U);
  EXPECT_EQ(mc.model->products[0], 0x0BB8U);
  EXPECT_EQ(mc.model->products[1], 0x0BB9U);
  EXPECT_EQ(mc.model->legacy_product_name, "MC1-2800-V02");
  EXPECT_TRUE(kNovotechnikMultiturn.lss_fastscan);
  EXPECT_FALSE(kNovotechnikMultiturn.scaling_on_bit_value);  // E§5.3 as printed
}

// F§7.3: vendor "ifm"; the product code is printed ambiguously, so any
// product of the vendor is an ifm RM device.
TEST(Families, IfmIsSelectedByVendorAlone) {
  EXPECT_EQ(kIfmVendor, 0x0069666DU);
  EXPECT_EQ(family_of(kIfmVendor, 0x4341), &kIfmRm);
  EXPECT_EQ(family_of(kIfmVendor, 0xDEAD), &kIfmRm);
  EXPECT_EQ(kIfmRm.simulated_product, kIfmPrintedProduct);
}

// F§7.4: 0x3000 = node-ID - 1, 0x3001 an index into 20..1000 kbit/s;
// F§6.3.4: save with reset = 0x2300 written with 0x55AAAA55.
TEST(Families, IfmAddressingQuirksAreF74) {
  EXPECT_EQ(kIfmRm.addressing.node_id_index, 0x3000);
  EXPECT_EQ(kIfmRm.addressing.node_id_offset, 1);
  EXPECT_EQ(kIfmRm.addressing.bitrate_index, 0x3001);
  EXPECT_TRUE(kIfmRm.addressing.bitrate_is_table_index);
  ASSERT_EQ(kIfmRm.addressing.bitrates.size(), 8U);
  EXPECT_EQ(kIfmRm.addressing.bitrates[3], 125);
  EXPECT_EQ(kIfmSaveWithResetObject, 0x2300);
  EXPECT_EQ(kIfmSaveWithResetCode, 0x55AAAA55U);
  EXPECT_EQ(kIfmRm.store.node_id, 1);  // F§7.3: 0x1010 has sub 1 only
  EXPECT_EQ(kIfmRm.factory_node_id, 32);  // F§5.3.1
}

// J§1.6.1 / J§1.10, E§11: node-ID with 0x1010/4 (RSX/RFX /1), communication /2.
TEST(Families, NovotechnikStorageSubIndices) {
  for (const Family* f : {&kNovotechnikRotary, &kNovotechnikMultiturn}) {
    EXPECT_EQ(f->store.communication, 2) << f->name;
    EXPECT_EQ(f->store.application, 3) << f->name;
    EXPECT_EQ(f->store.node_id, 4) << f->name;
    EXPECT_EQ(f->addressing.node_id_index, 0x2000) << f->name;
  }
  EXPECT_EQ(kRotaryLegacyNodeIdStoreSub, 1);
  EXPECT_EQ(kSaveSignature, 0x65766173U);  // "save", CiA 301 §7.5.2.13
}

TEST(Families, ModelNamesAreUniqueAndEveryEdsStemIsShipped) {
  std::set<std::string_view> names;
  for (const Family* f : all()) {
    for (const Model& m : f->models) {
      EXPECT_TRUE(names.insert(m.name).second) << m.name;
      const bool single = std::filesystem::exists(devices_dir() / (std::string(m.eds_stem) + ".eds"));
      const bool variants = std::filesystem::exists(devices_dir() / (std::string(m.eds_stem) + "-1ch.eds")) &&
                            std::filesystem::exists(devices_dir() / (std::string(m.eds_stem) + "-2ch.eds"));
      EXPECT_TRUE(single || variants) << m.name << ": no EDS " << m.eds_stem;
    }
  }
}
