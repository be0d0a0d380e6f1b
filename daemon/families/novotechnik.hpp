// Novotechnik, the maker of two families (rotary, manual J; multiturn,
// manual E): what the two share.
//
// Thread contract: constants; any thread.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string_view>

#include "families/family.hpp"

namespace cobridge::families {

inline constexpr std::uint32_t kNovotechnikVendor = 0x00000182;  // J§1.2.1, E§4.1 0x1018/1
// Bit rates of the ordering codes (J§1.2.2, E§3.1), written in kbit/s to
// 0x2001 (J§1.3.3, E§4.3).
inline constexpr std::array<std::uint16_t, 6> kNovotechnikBitRates{50, 125, 250, 500, 800, 1000};
// Factory node-ID (J§1.2.2, E§3.1); 250 kbit/s (ordering code _4) is cobridge-sim's choice.
inline constexpr std::uint8_t kNovotechnikFactoryNodeId = 127;

// Manufacturer EMCY codes of both families (J§1.8.1, E§9.1): a CAM state or
// the work-area state changed; the frames carry the new 0x6300 / 0x6400 value.
inline constexpr std::uint16_t kNovotechnikCamEmcy = 0x9080;
inline constexpr std::uint16_t kNovotechnikWorkAreaEmcy = 0x9090;

// What both manuals share of those frames: which of the two it is, and the
// new state in byte 7 (J§1.8.1, E§9.1); each family adds its own bytes.
[[nodiscard]] constexpr EmcyDetail novotechnik_emcy_detail(std::uint16_t code, const EmcyDetailBytes& b) noexcept {
  EmcyDetail d;
  if (code == kNovotechnikCamEmcy) d.kind = EmcyDetailKind::cam;
  if (code == kNovotechnikWorkAreaEmcy) d.kind = EmcyDetailKind::work_area;
  if (d.kind != EmcyDetailKind::none) d.state = b[4];
  return d;
}

// A Novotechnik family: node-ID 0x2000 and bit rate 0x2001 in kbit/s (J§1.3.3,
// E§4.3); node-ID and bit rate stored with 0x1010/4, communication with /2
// (/1 resets the TPDO COB-IDs), application with /3 (J§1.10, E§11).
struct NovotechnikFamily {
  FamilyId id;
  std::string_view name;
  std::string_view series;
  std::string_view manual;
  std::string_view manual_title;
  std::span<const Model> models;
  bool lss_fastscan;
  std::span<const std::uint16_t> manual_objects;
  bool scaling_on_bit_value;
  const EmcyTable* emcy;
};

[[nodiscard]] constexpr Family novotechnik_family(const NovotechnikFamily& f) {
  Family out;
  out.id = f.id;
  out.name = f.name;
  out.series = f.series;
  out.manual = f.manual;
  out.manual_title = f.manual_title;
  out.vendor = kNovotechnikVendor;
  out.models = f.models;
  out.factory_node_id = kNovotechnikFactoryNodeId;
  out.factory_bitrate_kbit = 250;
  out.lss_fastscan = f.lss_fastscan;
  out.addressing = Addressing{0x2000, 0, 0x2001, false, kNovotechnikBitRates};
  out.store = StoreSubs{2, 3, 4};
  out.manual_objects = f.manual_objects;
  out.scaling_on_bit_value = f.scaling_on_bit_value;
  out.emcy = f.emcy;
  return out;
}

}  // namespace cobridge::families
