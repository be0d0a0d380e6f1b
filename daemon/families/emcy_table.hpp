// EmcyTable: what one family's manual says its EMCY frames (CiA 301 §7.2.7)
// mean: the rows of its code table, the level each row has, the position
// value a row makes the position object read, and how the detail bytes of
// the CAM and work-area frames are laid out. Each family module defines its
// own table (novotechnik_rotary: J§1.8.1, novotechnik_multiturn: E§9.1; ifm
// documents none, F§4). The CiA 301 texts of the codes are not here: the
// canopen layer keeps the standard's table, and device/emcy_meaning combines
// the two (a family row first, the standard's text otherwise).
//
// A frame is `code_lo code_hi byte2 byte3 .. byte7`; byte 2 is the CiA error
// register unless the family says it is a sub-code (E§9.1).
//
// Thread contract: constant tables; any thread, no allocation.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string_view>

namespace cobridge::families {

// E§9.1 "Level" (0x2104 filters EMCY by it); the other manuals define none.
enum class EmcyLevel : std::uint8_t { unspecified, info, warn, error, hard };

// Frame bytes 3..7 (after the code and byte 2).
using EmcyDetailBytes = std::array<std::uint8_t, 5>;

// A row matches a frame byte it names; kAnyByte leaves that byte free.
inline constexpr std::int16_t kAnyByte = -1;

struct EmcyRow {
  std::uint16_t code = 0;
  std::int16_t byte2 = kAnyByte;
  std::int16_t byte3 = kAnyByte;
  std::int16_t byte4 = kAnyByte;
  EmcyLevel level = EmcyLevel::unspecified;
  bool error_reset = false;       // announces that the error condition is gone
  std::int32_t position = 0;      // what the position reads meanwhile; 0 = the row names none
  std::string_view text;

  [[nodiscard]] bool matches(std::uint16_t frame_code, std::uint8_t frame_byte2,
                             const EmcyDetailBytes& bytes) const noexcept;
};

// A position value a family reports instead of a position while an error is
// active (J§1.8, E§9.1), and what it means.
struct ErrorPosition {
  std::int32_t value = 0;
  std::string_view meaning;
};

// The data a CAM or work-area frame carries, decoded by the family's layout.
enum class EmcyDetailKind : std::uint8_t { none, cam, work_area };
struct EmcyDetail {
  EmcyDetailKind kind = EmcyDetailKind::none;
  std::int32_t channel = -1;  // -1: the frame names no channel
  std::int32_t cams = -1;     // CAMs the frame names (-1: none)
  bool changed_cams = false;  // `cams` are the ones that changed, not the CAM numbers
  std::uint8_t state = 0;     // the new 0x6300 / 0x6400 value (CiA 406)
  // The manual's own reading of a work-area state, where it lists one besides
  // the 0x6400 bits (E§9.1); empty otherwise.
  std::string_view state_listed_as;
};

struct EmcyTable {
  std::string_view source;  // the manual section: "J§1.8.1", "E§9.1"
  std::span<const EmcyRow> rows;
  bool byte2_is_subcode = false;  // E§9.1: byte 2 is part of a sub-code, not the error register
  std::span<const ErrorPosition> error_positions;
  // Decodes bytes 3..7 of a frame a row matched; kind none when it carries no data.
  EmcyDetail (*detail)(std::uint16_t code, const EmcyDetailBytes& bytes) noexcept = nullptr;

  // The first row that matches; nullptr when the manual lists none.
  [[nodiscard]] const EmcyRow* find(std::uint16_t code, std::uint8_t byte2,
                                    const EmcyDetailBytes& bytes) const noexcept;
  // The meaning of an error position value; empty when `position` is ordinary.
  [[nodiscard]] std::string_view error_position_meaning(std::int32_t position) const noexcept;
};

}  // namespace cobridge::families
