#include "device/storage.hpp"
#include "families/family_traits.hpp"

namespace cobridge::sim {

namespace {

enum Group : std::uint8_t { kNone, kComm, kCommCobId, kApp, kAppLate, kUser, kLegacyFactory };

Group novotechnik_group(std::uint16_t index, std::uint8_t sub) noexcept {
  switch (index) {
    case 0x100C: case 0x100D: case 0x1017: case 0x1029: case 0x1A00: case 0x1A01: case 0x1F80:
    case 0x2010: case 0x2104: case 0x230A: case 0x233A: case 0x235A: case 0x236A: case 0x6031:
      return kComm;
    case 0x1800: case 0x1801:
      return sub == 1 ? kCommCobId : kComm;
    case 0x2000: case 0x2001:
      return kUser;
    case 0x6000: case 0x6001: case 0x6002: case 0x6003: case 0x6010:
    case 0x6301: case 0x6302:
    case 0x6310: case 0x6311: case 0x6312: case 0x6313:
    case 0x6320: case 0x6321: case 0x6322: case 0x6323:
      return kApp;
    case 0x6330: case 0x6331: case 0x6332: case 0x6333: case 0x6401: case 0x6402:
      return kAppLate;
    default:
      return kNone;  // 0x1005 COB-ID SYNC has no mark in either table
  }
}

bool ifm_stored(std::uint16_t index) noexcept {
  switch (index) {
    case 0x1005: case 0x100C: case 0x100D: case 0x1016: case 0x1017: case 0x1020: case 0x1800:
    case 0x1801: case 0x1A00: case 0x1A01: case 0x2100: case 0x2101: case 0x2102: case 0x2103:
    case 0x2104: case 0x2105: case 0x2160: case 0x2200: case 0x3000: case 0x3001: case 0x6000:
    case 0x6001: case 0x6002: case 0x6003: case 0x6200: case 0x6401: case 0x6402:
      return true;
    default:
      return false;
  }
}

}  // namespace

Coverage store_coverage(FamilyId family, bool legacy, std::uint8_t store_sub, std::uint16_t index,
                        std::uint8_t sub) noexcept {
  switch (family) {
    case FamilyId::ifm_rm: return store_sub == 1 && ifm_stored(index) ? Coverage::value : Coverage::none;
    case FamilyId::novotechnik_rotary: break;
    case FamilyId::novotechnik_multiturn: break;
  }
  const Group g = novotechnik_group(index, sub);
  switch (store_sub) {
    case 1:
      switch (g) {
        case kComm: case kApp: return Coverage::value;
        case kCommCobId: return Coverage::default_value;
        case kAppLate: return legacy ? Coverage::none : Coverage::value;
        case kUser: return legacy ? Coverage::value : Coverage::none;
        default: return Coverage::none;
      }
    case 2: return g == kComm || g == kCommCobId ? Coverage::value : Coverage::none;
    case 3: return g == kApp || g == kAppLate ? Coverage::value : Coverage::none;
    case 4: return g == kUser && !legacy ? Coverage::value : Coverage::none;
    default: return Coverage::none;
  }
}

std::uint8_t store_sub_count(FamilyId family) noexcept { return families::traits(family).store_subs; }

}  // namespace cobridge::sim
