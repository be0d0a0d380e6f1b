#include "config/known_models.hpp"

#include <array>

namespace cobridge::config {
namespace {

constexpr std::uint32_t kNovotechnik = 0x00000182;  // J§1.2.1, E§4.1
constexpr std::uint32_t kIfm = 0x0069666D;          // "ifm", F§7.3 0x1018

// J§1.2.1 product codes.
constexpr std::array<std::uint32_t, 1> kRfc4800{0x0BE0};
constexpr std::array<std::uint32_t, 1> kRsa3200{0x0BF3};
constexpr std::array<std::uint32_t, 1> kRfe3200{0x0BBD};
constexpr std::array<std::uint32_t, 1> kRsx7900{0x0BCD};
constexpr std::array<std::uint32_t, 1> kRfx6900{0x0BE1};
// E§13 V03: every multiturn model now reports 0x0BB8; before V03 each had its
// own code. Both generations are in the field, so both are accepted.
constexpr std::array<std::uint32_t, 2> kMz12200{0x0BB8, 0x0BD5};
constexpr std::array<std::uint32_t, 2> kMc12800{0x0BB8, 0x0BB9};
constexpr std::array<std::uint32_t, 2> kMb13600{0x0BB8, 0x0BBC};

// Rotary: 1- and 2-channel variants, 4 CAMs per channel (J§1.2.3), moving
// average in 0x6000 bits 14..12 (J§1.4.1), no separate speed filter.
// ifm: one channel, CAMs 1..8 (F§7.5 0x6300..0x6337), no filter objects.
// Multiturn: one channel, 4 CAMs (E§3.4), position and speed filters in
// 0x2010 (E§5.1, E§5.2).
// RM8000/RM9000 are the device names F§7.3 prints in 0x1008 (and cobridge-sim
// uses); RM8/RM9 name the same series.
constexpr std::array<KnownModel, 12> kModels{{
    {"RFC-4800", Family::novotechnik_rotary, kNovotechnik, kRfc4800, 2, 4, true, false},
    {"RSA-3200", Family::novotechnik_rotary, kNovotechnik, kRsa3200, 2, 4, true, false},
    {"RFE-3200", Family::novotechnik_rotary, kNovotechnik, kRfe3200, 2, 4, true, false},
    {"RSX-7900", Family::novotechnik_rotary, kNovotechnik, kRsx7900, 2, 4, true, false},
    {"RFX-6900", Family::novotechnik_rotary, kNovotechnik, kRfx6900, 2, 4, true, false},
    {"MZ1-2200", Family::novotechnik_multiturn, kNovotechnik, kMz12200, 1, 4, true, true},
    {"MC1-2800", Family::novotechnik_multiturn, kNovotechnik, kMc12800, 1, 4, true, true},
    {"MB1-3600", Family::novotechnik_multiturn, kNovotechnik, kMb13600, 1, 4, true, true},
    {"RM8", Family::ifm_rm, kIfm, {}, 1, 8, false, false},
    {"RM9", Family::ifm_rm, kIfm, {}, 1, 8, false, false},
    {"RM8000", Family::ifm_rm, kIfm, {}, 1, 8, false, false},
    {"RM9000", Family::ifm_rm, kIfm, {}, 1, 8, false, false},
}};

}  // namespace

std::span<const KnownModel> known_models() noexcept { return kModels; }

const KnownModel* find_model(std::string_view name) noexcept {
  for (const auto& m : kModels) {
    if (m.name == name) return &m;
  }
  return nullptr;
}

}  // namespace cobridge::config
