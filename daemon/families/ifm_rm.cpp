// ifm RM8/RM9 series (manual F): see ifm_rm.hpp.
#include "families/ifm_rm.hpp"

#include <array>

namespace cobridge::families {

namespace {

// One channel, CAMs 1..8 (F§7.5 0x6300..0x6337), no filter objects.
// RM8000/RM9000 are the device names F§7.3 prints in 0x1008 (and cobridge-sim
// uses); RM8/RM9 name the same series in the configuration.
constexpr Model ifm_model(std::string_view name, bool simulated) {
  return Model{name, {}, 1, 8, false, false, false, simulated, {}, "ifm-rm8-rm9"};
}

constexpr std::array<Model, 4> kModels{{
    ifm_model("RM8", false),
    ifm_model("RM9", false),
    ifm_model("RM8000", true),
    ifm_model("RM9000", true),
}};

// The objects F§7.3-F§7.5 name.
constexpr std::array<std::uint16_t, 87> kManualObjects{
    0x1000, 0x1001, 0x1003, 0x1005, 0x1006, 0x1007, 0x1008, 0x1009, 0x100A, 0x100C,
    0x100D, 0x1010, 0x1011, 0x1012, 0x1013, 0x1014, 0x1016, 0x1017, 0x1018, 0x1020,
    0x1029, 0x1800, 0x1801, 0x1A00, 0x1A01, 0x1F50, 0x1F51, 0x2000, 0x2100, 0x2101,
    0x2102, 0x2103, 0x2104, 0x2105, 0x2160, 0x2200, 0x2300, 0x3000, 0x3001, 0x3010,
    0x3011, 0x4000, 0x6000, 0x6001, 0x6002, 0x6003, 0x6004, 0x6030, 0x6200, 0x6300,
    0x6301, 0x6302, 0x6310, 0x6311, 0x6312, 0x6313, 0x6314, 0x6315, 0x6316, 0x6317,
    0x6320, 0x6321, 0x6322, 0x6323, 0x6324, 0x6325, 0x6326, 0x6327, 0x6330, 0x6331,
    0x6332, 0x6333, 0x6334, 0x6335, 0x6336, 0x6337, 0x6400, 0x6401, 0x6402, 0x6500,
    0x6501, 0x6502, 0x6504, 0x6507, 0x6509, 0x650A, 0x650B,
};

}  // namespace

const Family kIfmRm{
    .id = FamilyId::ifm_rm,
    .name = "ifm-rm",
    .series = "ifm RM series",
    .manual = "F",
    .manual_title = "ifm RM8xxx/RM9xxx operating instructions",
    .vendor = kIfmVendor,
    .models = kModels,
    .match_any_product = true,
    .simulated_product = kIfmPrintedProduct,
    .factory_node_id = 32,         // F§5.3.1
    .factory_bitrate_kbit = 125,   // F§5.3.2
    .lss_fastscan = true,
    .addressing = Addressing{0x3000, 1, 0x3001, true, kIfmBitRates},  // F§7.4
    .store = StoreSubs{1, 1, 1},   // F§7.3: 0x1010 has sub 1 only
    .manual_objects = kManualObjects,
    .scaling_on_bit_value = true,  // F§7.5 SFC
    .emcy = nullptr,               // F§4: no EMCY code table
};

}  // namespace cobridge::families
