// The ifm RM module's EMCY facts (families/ifm_rm), checked against manual F.
#include "families/ifm_rm.hpp"

#include <gtest/gtest.h>

namespace cobridge::families {
namespace {

// F§4 / F§7.3 0x1003: one EMCY object but no code table, so the module
// carries none and only the CiA 301 texts apply (device/emcy_meaning).
TEST(IfmRmEmcy, F4_NoCodeTable) {
  EXPECT_EQ(kIfmRm.emcy, nullptr);
  EXPECT_EQ(family(FamilyId::ifm_rm).emcy, nullptr);
}

}  // namespace
}  // namespace cobridge::families
