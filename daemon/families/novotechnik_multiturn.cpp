// Novotechnik multiturn series (manual E): see novotechnik_multiturn.hpp.
#include "families/novotechnik_multiturn.hpp"

#include <array>

#include "families/novotechnik.hpp"

namespace cobridge::device::families {

namespace {

constexpr std::array<std::uint32_t, 2> kMz12200{kMultiturnProduct, kMz12200V02Product};
constexpr std::array<std::uint32_t, 2> kMc12800{kMultiturnProduct, kMc12800V02Product};
constexpr std::array<std::uint32_t, 2> kMb13600{kMultiturnProduct, kMb13600V02Product};

// One channel, 4 CAMs (E§3.4), position and speed filters in 0x2010 (E§5.1, E§5.2).
constexpr Model multiturn_model(std::string_view name, std::span<const std::uint32_t> products,
                                std::string_view legacy_name) {
  return Model{name, products, 1, 4, true, true, false, true, legacy_name, "novotechnik-multiturn"};
}

constexpr std::array<Model, 3> kModels{{
    multiturn_model("MZ1-2200", kMz12200, "MZ1-2200-V02"),
    multiturn_model("MC1-2800", kMc12800, "MC1-2800-V02"),
    multiturn_model("MB1-3600", kMb13600, "MB1-3600-V02"),
}};

// The objects E§4.1-E§4.3 name.
constexpr std::array<std::uint16_t, 83> kManualObjects{
    0x1000, 0x1001, 0x1002, 0x1005, 0x1008, 0x1009, 0x100A, 0x100C, 0x100D, 0x1010,
    0x1011, 0x1014, 0x1017, 0x1018, 0x1029, 0x1800, 0x1801, 0x1A00, 0x1A01, 0x1F80,
    0x2000, 0x2001, 0x2002, 0x2003, 0x2010, 0x2100, 0x2101, 0x2104, 0x2300, 0x230A,
    0x2310, 0x2320, 0x232A, 0x2330, 0x233A, 0x2340, 0x234A, 0x2350, 0x235A, 0x235B,
    0x2360, 0x236A, 0x236B, 0x6000, 0x6001, 0x6002, 0x6003, 0x6004, 0x600C, 0x6030,
    0x6031, 0x6300, 0x6301, 0x6302, 0x6310, 0x6311, 0x6312, 0x6313, 0x6320, 0x6321,
    0x6322, 0x6323, 0x6330, 0x6331, 0x6332, 0x6333, 0x6400, 0x6401, 0x6402, 0x6500,
    0x6501, 0x6502, 0x6503, 0x6504, 0x6505, 0x6506, 0x6507, 0x6508, 0x6509, 0x650A,
    0x650B, 0x650D, 0x650E,
};

}  // namespace

const Family kNovotechnikMultiturn = novotechnik_family({
    .name = "novotechnik-multiturn",
    .series = "multiturn series",
    .manual = "E",
    .models = kModels,
    .lss_fastscan = true,  // CiA 305 V3.0.0 (E§6)
    .manual_objects = kManualObjects,
    .scaling_on_bit_value = false,  // E§5.3 as printed: 0 = scaling on
});

}  // namespace cobridge::device::families
