// Novotechnik multiturn series (manual E): see novotechnik_multiturn.hpp.
#include "families/novotechnik_multiturn.hpp"

#include <array>

#include "families/novotechnik.hpp"

namespace cobridge::families {

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

constexpr EmcyRow row(std::uint16_t code, std::uint8_t byte2, std::uint8_t byte3, EmcyLevel level,
                      std::int32_t position, std::string_view text) {
  // E§9.1: 0x0000 and 0x5051/0 ("valid position") announce that the error is gone.
  const bool reset = code == 0x0000 || (code == kMultiturnMeasurementEmcy && byte2 == 0);
  return EmcyRow{code, byte2, byte3, kAnyByte, level, reset, position, text};
}

constexpr std::int32_t kError = kMultiturnErrorPosition;
constexpr std::int32_t kOver = kMultiturnOverflowPosition;
constexpr std::int32_t kUnder = kMultiturnUnderflowPosition;
using L = EmcyLevel;

// E§9.1, row by row: (code, byte 2, byte 3) -> level, position value, text.
constexpr std::array<EmcyRow, 26> kEmcyRows{{
    row(0x0000, 0, 0, L::hard, 0, "sensor error reset, no error"),
    row(0x1000, 1, 0, L::hard, kError, "unknown error"),
    row(0x3100, 1, 0, L::error, 0, "supply voltage fault"),
    row(0x3100, 1, 1, L::warn, 0, "supply voltage overrun (factory-set threshold max exceeded)"),
    row(0x3100, 1, 2, L::warn, 0, "supply voltage underrun (factory-set threshold min exceeded)"),
    row(0x4210, 1, 1, L::warn, 0, "temperature overrun (factory-set threshold max exceeded)"),
    row(0x4210, 1, 2, L::warn, 0, "temperature underrun (factory-set threshold min exceeded)"),
    row(0x5000, 1, 0, L::hard, kError, "device hardware fault"),
    row(0x5000, 0, 0, L::info, 0, "life guarding error"),
    row(0x5000, 0, 1, L::info, 0, "maintenance required (operating time limit)"),
    row(0x5000, 1, 2, L::hard, kError, "hardware ASIC fault"),
    row(0x5000, 2, 0, L::hard, 0, "memory lost"),
    row(0x5051, 0, 0, L::unspecified, 0, "valid position"),
    row(0x5051, 1, 0, L::error, kError, "measurement error"),
    row(0x5051, 1, 1, L::error, kOver, "position overflow error, out of range (+); reset via 0x2100"),
    row(0x5051, 1, 2, L::error, kUnder, "position underflow error, out of range (-); reset via 0x2100"),
    row(0x5051, 2, 1, L::warn, kOver, "position overflow warning"),
    row(0x5051, 2, 2, L::warn, kUnder, "position underflow warning"),
    row(0x6000, 1, 0, L::hard, kError, "device software fault"),
    row(0x6000, 2, 0, L::hard, 0, "insufficient event timer value for the bit rate; TPDO1 sent only partially"),
    row(0x8110, 1, 0, L::hard, 0, "CAN controller overflow, CAN overrun; data lost"),
    row(0x8110, 2, 0, L::hard, 0, "CAN buffer overflow (CANopen library buffer full); data lost"),
    row(0x8120, 0, 0, L::hard, 0, "CAN error passive"),
    row(0x8140, 0, 0, L::hard, 0, "CAN recovered from bus-off"),
    row(kNovotechnikCamEmcy, 1, 0, L::warn, 0, "encoder CAM state changed"),
    row(kNovotechnikWorkAreaEmcy, 1, 0, L::warn, 0, "work area state changed"),
}};

constexpr std::array<ErrorPosition, 3> kErrorPositions{{
    {kMultiturnErrorPosition, "measurement, unknown, hardware, ASIC or software error (E§9.1)"},
    {kMultiturnOverflowPosition, "position out of range (+) (E§9.1)"},
    {kMultiturnUnderflowPosition, "position out of range (-) (E§9.1)"},
}};

// E§9.1 codes the work-area state "according to 0x6400" and also lists
// 0/1/2 = valid/underflow/overflow; the two disagree, so both are given.
std::string_view listed_work_area_state(std::uint8_t state) noexcept {
  switch (state) {
    case 0: return "valid";
    case 1: return "underflow";
    case 2: return "overflow";
    default: return "?";
  }
}

// E§9.1: the CAM frame names the changed CAMs in byte 4; no channel.
EmcyDetail emcy_detail(std::uint16_t code, const EmcyDetailBytes& b) noexcept {
  EmcyDetail d = novotechnik_emcy_detail(code, b);
  if (d.kind == EmcyDetailKind::cam) {
    d.cams = b[1];
    d.changed_cams = true;
  }
  if (d.kind == EmcyDetailKind::work_area) d.state_listed_as = listed_work_area_state(b[4]);
  return d;
}

// Byte 2 and byte 3 form a sub-code (E§9.1).
constexpr EmcyTable kEmcy{
    .source = "E§9.1", .rows = kEmcyRows, .byte2_is_subcode = true, .error_positions = kErrorPositions,
    .detail = emcy_detail};

}  // namespace

const Family kNovotechnikMultiturn = novotechnik_family({
    .id = FamilyId::novotechnik_multiturn,
    .name = "novotechnik-multiturn",
    .series = "multiturn series",
    .manual = "E",
    .manual_title = "Novotechnik multiturn MZ1/MC1/MB1 CANopen manual",
    .models = kModels,
    .lss_fastscan = true,  // CiA 305 V3.0.0 (E§6)
    .manual_objects = kManualObjects,
    .scaling_on_bit_value = false,  // E§5.3 as printed: 0 = scaling on
    .emcy = &kEmcy,
});

EmcyDetailBytes multiturn_cam_emcy_bytes(std::uint8_t changed, std::uint8_t state) noexcept {
  return {0, changed, 0, 0, state};
}

EmcyDetailBytes multiturn_work_area_emcy_bytes(std::uint8_t state) noexcept { return {0, 0, 0, 0, state}; }

}  // namespace cobridge::families
