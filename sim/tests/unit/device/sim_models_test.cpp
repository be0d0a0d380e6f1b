// cobridge-sim's model table, built from the device families
// (daemon/families): names, product codes, factory node-IDs and bit
// rates as the manuals give them (J§1.2.1, J§1.2.2, E§4.1, E§13 V03, F§5.3,
// F§7.3).
#include "device/sim_device.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace cobridge::sim {
namespace {

TEST(SimModels, TableListsEveryFamilyModelThenItsPreV03Twins) {
  std::vector<std::string> names;
  for (const ModelInfo& m : all_models()) names.emplace_back(m.name);
  EXPECT_EQ(names, (std::vector<std::string>{"RFC-4800", "RSA-3200", "RFE-3200", "RSX-7900", "RFX-6900", "MZ1-2200",
                                             "MC1-2800", "MB1-3600", "MZ1-2200-V02", "MC1-2800-V02", "MB1-3600-V02",
                                             "RM8000", "RM9000"}));
}

// J§1.2.1 codes, node-ID 127; RSX-7900 / RFX-6900 run the J§1.12 V10 rules.
TEST(SimModels, RotaryIdentityAndLegacyFirmware) {
  const ModelInfo* rsx = find_model("rsx-7900");  // case-insensitive
  ASSERT_NE(rsx, nullptr);
  EXPECT_EQ(rsx->vendor, 0x00000182U);
  EXPECT_EQ(rsx->product, 0x0BCDU);
  EXPECT_TRUE(rsx->legacy_rsx_rfx);
  EXPECT_EQ(rsx->factory_node_id, 127);
  EXPECT_EQ(rsx->eds_stem, "novotechnik-rsx7900");
  EXPECT_FALSE(find_model("RFC-4800")->legacy_rsx_rfx);
}

// E§13 V03: 0x0BB8 since V03; the -V02 models report the codes before it.
TEST(SimModels, MultiturnBothProductCodeGenerations) {
  EXPECT_EQ(find_model("MC1-2800")->product, 0x0BB8U);
  EXPECT_EQ(find_model("MZ1-2200-V02")->product, 0x0BD5U);
  EXPECT_EQ(find_model("MC1-2800-V02")->product, 0x0BB9U);
  EXPECT_EQ(find_model("MB1-3600-V02")->product, 0x0BBCU);
  EXPECT_EQ(find_model("MB1-3600-V02")->family, FamilyId::novotechnik_multiturn);
  EXPECT_EQ(find_model("MB1-3600-V02")->eds_stem, "novotechnik-multiturn");
}

// F§7.3 vendor "ifm", product read as 0x00004341; F§5.3.1 node 32, F§5.3.2 125 kbit/s.
TEST(SimModels, IfmIdentityAndFactorySettings) {
  const ModelInfo* rm = find_model("RM9000");
  ASSERT_NE(rm, nullptr);
  EXPECT_EQ(rm->vendor, 0x0069666DU);
  EXPECT_EQ(rm->product, 0x00004341U);
  EXPECT_EQ(rm->factory_node_id, 32);
  EXPECT_EQ(rm->factory_bitrate_kbit, 125);
  EXPECT_EQ(family_name(rm->family), "ifm-rm");
  EXPECT_EQ(find_model("RM9"), nullptr) << "RM8/RM9 are configuration names, not simulated models";
}

}  // namespace
}  // namespace cobridge::sim
