// Novotechnik rotary series (manual J): see novotechnik_rotary.hpp.
#include "families/novotechnik_rotary.hpp"

#include <array>

#include "families/novotechnik.hpp"

namespace cobridge::families {

namespace {

constexpr std::array<std::uint32_t, 1> kRfc4800{kRfc4800Product};
constexpr std::array<std::uint32_t, 1> kRsa3200{kRsa3200Product};
constexpr std::array<std::uint32_t, 1> kRfe3200{kRfe3200Product};
constexpr std::array<std::uint32_t, 1> kRsx7900{kRsx7900Product};
constexpr std::array<std::uint32_t, 1> kRfx6900{kRfx6900Product};

// 1- and 2-channel variants, 4 CAMs per channel (J§1.2.3), moving average in
// 0x6000 (J§1.4.1), no separate speed filter.
constexpr Model rotary_model(std::string_view name, std::span<const std::uint32_t> products, bool legacy,
                             std::string_view stem) {
  return Model{name, products, 2, 4, true, false, legacy, true, {}, stem};
}

constexpr std::array<Model, 5> kModels{{
    rotary_model("RFC-4800", kRfc4800, false, "novotechnik-rfc4800"),
    rotary_model("RSA-3200", kRsa3200, false, "novotechnik-rsa3200"),
    rotary_model("RFE-3200", kRfe3200, false, "novotechnik-rfe3200"),
    rotary_model("RSX-7900", kRsx7900, true, "novotechnik-rsx7900"),
    rotary_model("RFX-6900", kRfx6900, true, "novotechnik-rfx6900"),
}};

// The objects J§1.3.1-J§1.3.3 name. 0x2003 "ordering" and 0x2004 "custom" are left out:
// J gives them no type, access or sub-indices and says they are not writable by customers.
constexpr std::array<std::uint16_t, 53> kManualObjects{
    0x1000, 0x1001, 0x1002, 0x1005, 0x1008, 0x1009, 0x100A, 0x100C, 0x100D, 0x1010,
    0x1011, 0x1014, 0x1017, 0x1018, 0x1800, 0x1801, 0x1A00, 0x1A01, 0x1F80, 0x2000,
    0x2001, 0x6000, 0x6001, 0x6002, 0x6010, 0x6020, 0x6030, 0x6300, 0x6301, 0x6302,
    0x6310, 0x6311, 0x6312, 0x6313, 0x6320, 0x6321, 0x6322, 0x6323, 0x6330, 0x6331,
    0x6332, 0x6333, 0x6400, 0x6401, 0x6402, 0x6500, 0x6501, 0x6502, 0x6503, 0x6504,
    0x6505, 0x6506, 0x6507,
};

std::uint16_t le16(const EmcyDetailBytes& b, std::size_t first) noexcept {
  return static_cast<std::uint16_t>(b[first] | (b[first + 1] << 8));
}

// J§1.8.1, row by row. Byte 2 is the error register, so no row names it; the
// 0x8110 rows differ in bytes 3-4 (1 overrun, 2 buffer overflow).
constexpr std::array<EmcyRow, 9> kEmcyRows{{
    {.code = 0x0000, .error_reset = true, .text = "sensor error reset, no error"},
    {.code = 0x5000, .text = "sensor error (internal error bit set)"},
    {.code = 0x6000, .text = "event timer value insufficient for the bit rate; TPDO1 sent only partially"},
    {.code = 0x8110, .byte3 = 1, .byte4 = 0, .text = "CAN controller overflow, CAN overrun; data lost"},
    {.code = 0x8110, .byte3 = 2, .byte4 = 0, .text = "CAN buffer overflow (CANopen library buffer full); data lost"},
    {.code = 0x8120, .text = "CAN error passive"},
    {.code = 0x8140, .text = "CAN recovered from bus-off"},
    {.code = kNovotechnikCamEmcy, .text = "encoder CAM state changed (coded as 0x6300)"},
    {.code = kNovotechnikWorkAreaEmcy, .text = "work area state changed (coded as 0x6400)"},
}};

constexpr std::array<ErrorPosition, 1> kErrorPositions{{
    {kRotaryErrorPosition, "position or sensor error (J§1.8)"},
}};

// J§1.8.1: both frames name the channel in bytes 3-4; the CAM frame the CAMs in bytes 5-6.
EmcyDetail emcy_detail(std::uint16_t code, const EmcyDetailBytes& b) noexcept {
  EmcyDetail d = novotechnik_emcy_detail(code, b);
  if (d.kind == EmcyDetailKind::none) return d;
  d.channel = le16(b, 0);
  if (d.kind == EmcyDetailKind::cam) d.cams = le16(b, 2);
  return d;
}

// Byte 2 is the CiA error register (byte2_is_subcode false).
constexpr EmcyTable kEmcy{
    .source = "J§1.8.1", .rows = kEmcyRows, .error_positions = kErrorPositions, .detail = emcy_detail};

}  // namespace

const Family kNovotechnikRotary = novotechnik_family({
    .id = FamilyId::novotechnik_rotary,
    .name = "novotechnik-rotary",
    .series = "rotary series",
    .manual = "J",
    .manual_title = "Novotechnik rotary CANopen manual",
    .models = kModels,
    .lss_fastscan = false,  // DSP-305 V1.1.2 (J§1 intro), older than Fastscan
    .manual_objects = kManualObjects,
    .scaling_on_bit_value = true,  // J§1.4.1
    .emcy = &kEmcy,
});

bool is_legacy_rsx_rfx(std::uint32_t product) noexcept {
  return product == kRsx7900Product || product == kRfx6900Product;
}

EmcyDetailBytes rotary_cam_emcy_bytes(std::uint16_t channel, std::uint16_t cams, std::uint8_t state) noexcept {
  return {static_cast<std::uint8_t>(channel & 0xFF), static_cast<std::uint8_t>(channel >> 8),
          static_cast<std::uint8_t>(cams & 0xFF), static_cast<std::uint8_t>(cams >> 8), state};
}

EmcyDetailBytes rotary_work_area_emcy_bytes(std::uint16_t channel, std::uint8_t state) noexcept {
  return {static_cast<std::uint8_t>(channel & 0xFF), static_cast<std::uint8_t>(channel >> 8), 0, 0, state};
}

}  // namespace cobridge::families
