// The model table behind `--device MODEL`: which product codes, factory
// node-IDs, bit rates and EDS files the simulated encoders use.
//
// Sources: J§1.2.1 (rotary product codes), E§4.1 / E§13 V03 (multiturn
// 0x0BB8 since V03; the "-V02" rows report the codes printed before V03),
// F§7.3 (ifm vendor "ifm", product printed "0x43 0x41", read as 0x00004341
// like the EDS file), J§1.2.2 / E§3.1 (node-ID 127), F§5.3.1 (node-ID 32).
// Novotechnik bit rates come from the ordering code; 250 kbit/s (code 6_4)
// is the simulator's choice. ifm ships at 125 kbit/s (F§5.3.2).
#include "device/sim_device.hpp"

#include <array>
#include <cctype>

namespace cobridge::sim {

namespace {

constexpr std::uint32_t kNovotechnik = 0x00000182;
constexpr std::uint32_t kIfm = 0x0069666D;

constexpr std::array<ModelInfo, 13> kModels{{
    {"RFC-4800", Family::novotechnik_rotary, kNovotechnik, 0x0BE0, 127, false, "novotechnik-rfc4800", 250},
    {"RSA-3200", Family::novotechnik_rotary, kNovotechnik, 0x0BF3, 127, false, "novotechnik-rsa3200", 250},
    {"RFE-3200", Family::novotechnik_rotary, kNovotechnik, 0x0BBD, 127, false, "novotechnik-rfe3200", 250},
    {"RSX-7900", Family::novotechnik_rotary, kNovotechnik, 0x0BCD, 127, true, "novotechnik-rsx7900", 250},
    {"RFX-6900", Family::novotechnik_rotary, kNovotechnik, 0x0BE1, 127, true, "novotechnik-rfx6900", 250},
    {"MZ1-2200", Family::novotechnik_multiturn, kNovotechnik, 0x0BB8, 127, false, "novotechnik-multiturn", 250},
    {"MC1-2800", Family::novotechnik_multiturn, kNovotechnik, 0x0BB8, 127, false, "novotechnik-multiturn", 250},
    {"MB1-3600", Family::novotechnik_multiturn, kNovotechnik, 0x0BB8, 127, false, "novotechnik-multiturn", 250},
    {"MZ1-2200-V02", Family::novotechnik_multiturn, kNovotechnik, 0x0BD5, 127, false, "novotechnik-multiturn", 250},
    {"MC1-2800-V02", Family::novotechnik_multiturn, kNovotechnik, 0x0BB9, 127, false, "novotechnik-multiturn", 250},
    {"MB1-3600-V02", Family::novotechnik_multiturn, kNovotechnik, 0x0BBC, 127, false, "novotechnik-multiturn", 250},
    {"RM9000", Family::ifm_rm, kIfm, 0x00004341, 32, false, "ifm-rm8-rm9", 125},
    {"RM8000", Family::ifm_rm, kIfm, 0x00004341, 32, false, "ifm-rm8-rm9", 125},
}};

bool equal_ignore_case(std::string_view a, std::string_view b) noexcept {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto ca = static_cast<unsigned char>(a[i]);
    const auto cb = static_cast<unsigned char>(b[i]);
    if (std::tolower(ca) != std::tolower(cb)) return false;
  }
  return true;
}

}  // namespace

const ModelInfo* find_model(std::string_view name) noexcept {
  for (const ModelInfo& m : kModels)
    if (equal_ignore_case(m.name, name)) return &m;
  return nullptr;
}

std::span<const ModelInfo> all_models() noexcept { return kModels; }

std::string_view family_name(Family f) noexcept {
  switch (f) {
    case Family::novotechnik_rotary: return "novotechnik-rotary";
    case Family::novotechnik_multiturn: return "novotechnik-multiturn";
    case Family::ifm_rm: return "ifm-rm";
  }
  return "unknown";
}

}  // namespace cobridge::sim
