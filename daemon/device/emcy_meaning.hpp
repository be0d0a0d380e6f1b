// EmcyMeaning: what an EMCY (CiA 301 §7.2.7) from a device of a known family
// means: the row of the family's own table (daemon/families, EmcyTable:
// J§1.8.1, E§9.1) when one matches, else the CiA 301 text of the code
// (canopen/emcy). The one lookup the gateway's log and status and the plugin
// SDK (cobridge/emcy.h, hence the DDS and Modbus outputs) use.
//
// Thread contract: any thread. `classify_emcy()` is noexcept and returns
// static text; `describe_emcy()` builds a std::string and belongs off the hot
// path (the gateway's log line, the status report).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "canopen/emcy.hpp"
#include "families/family.hpp"

namespace cobridge::device {

using families::EmcyLevel;
[[nodiscard]] std::string_view to_string(EmcyLevel level) noexcept;

struct EmcyInfo {
  std::string_view text;       // the manual's meaning, else the CiA 301 text
  std::string_view source;     // the manual section ("J§1.8.1", "E§9.1") or "CiA 301"
  EmcyLevel level = EmcyLevel::unspecified;
  bool from_manual = false;    // a row of the family's own table matched
  bool error_reset = false;    // announces that the error condition is gone
  std::optional<std::int32_t> position_value;  // what the position reads meanwhile (E§9.1)
};

// `family` nullptr: a device no family knows, CiA 301 texts only.
[[nodiscard]] EmcyInfo classify_emcy(const families::Family* family, const canopen::Emcy& emcy) noexcept;

// One log line: code, meaning, source, level and the decoded detail bytes
// (channel, CAMs, work-area state). Allocates.
[[nodiscard]] std::string describe_emcy(const families::Family* family, const canopen::Emcy& emcy);

// What a position object reads while an error is active (J§1.8, E§9.1);
// nullopt when `position` is an ordinary value or the family names none.
[[nodiscard]] std::optional<std::string_view> error_position_meaning(const families::Family* family,
                                                                     std::int32_t position) noexcept;

}  // namespace cobridge::device
