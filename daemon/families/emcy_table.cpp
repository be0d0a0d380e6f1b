// A family's EMCY table: see emcy_table.hpp.
#include "families/emcy_table.hpp"

namespace cobridge::families {

namespace {
bool byte_matches(std::int16_t want, std::uint8_t got) noexcept { return want == kAnyByte || want == got; }
}  // namespace

bool EmcyRow::matches(std::uint16_t frame_code, std::uint8_t frame_byte2,
                      const EmcyDetailBytes& bytes) const noexcept {
  return code == frame_code && byte_matches(byte2, frame_byte2) && byte_matches(byte3, bytes[0]) &&
         byte_matches(byte4, bytes[1]);
}

const EmcyRow* EmcyTable::find(std::uint16_t code, std::uint8_t byte2, const EmcyDetailBytes& bytes) const noexcept {
  for (const EmcyRow& row : rows) {
    if (row.matches(code, byte2, bytes)) return &row;
  }
  return nullptr;
}

std::string_view EmcyTable::error_position_meaning(std::int32_t position) const noexcept {
  for (const ErrorPosition& p : error_positions) {
    if (p.value == position) return p.meaning;
  }
  return {};
}

}  // namespace cobridge::families
