// The SDK's C face of canopen/emcy: family names as plugins see them, and
// the classification of the daemon's own table (no second copy).
#include <cobridge/emcy.h>

#include <cstring>
#include <string>
#include <string_view>

#include "canopen/emcy.hpp"

namespace {

using cobridge::canopen::DeviceFamily;
using cobridge::canopen::EmcyLevel;

static_assert(static_cast<int>(EmcyLevel::info) == COBRIDGE_EMCY_LEVEL_INFO &&
                  static_cast<int>(EmcyLevel::warn) == COBRIDGE_EMCY_LEVEL_WARN &&
                  static_cast<int>(EmcyLevel::error) == COBRIDGE_EMCY_LEVEL_ERROR &&
                  static_cast<int>(EmcyLevel::hard) == COBRIDGE_EMCY_LEVEL_HARD,
              "cobridge/emcy.h levels must equal canopen::EmcyLevel");

// The EDS [Cobridge] Family names, with '-' or '_'.
DeviceFamily family_from_name(const char* family) noexcept {
  const std::string_view f = family != nullptr ? family : "";
  if (f == "novotechnik-rotary" || f == "novotechnik_rotary") return DeviceFamily::novotechnik_rotary;
  if (f == "novotechnik-multiturn" || f == "novotechnik_multiturn") return DeviceFamily::novotechnik_multiturn;
  if (f == "ifm-rm" || f == "ifm_rm") return DeviceFamily::ifm_rm;
  return DeviceFamily::generic;
}

cobridge::canopen::Emcy make(uint16_t code, uint8_t reg, const uint8_t* manufacturer) noexcept {
  cobridge::canopen::Emcy e;
  e.error_code = code;
  e.error_register = reg;
  if (manufacturer != nullptr) std::memcpy(e.manufacturer.data(), manufacturer, e.manufacturer.size());
  return e;
}

}  // namespace

extern "C" int cobridge_emcy_classify(const char* family, uint16_t error_code, uint8_t error_register,
                                      const uint8_t* manufacturer, cobridge_emcy_info* out) {
  if (out == nullptr) return -1;
  const auto info = cobridge::canopen::classify(family_from_name(family), make(error_code, error_register, manufacturer));
  out->text = info.text.data();
  out->text_len = info.text.size();
  out->source = info.source.data();
  out->source_len = info.source.size();
  out->level = static_cast<int>(info.level);
  out->from_manual = info.from_manual ? 1 : 0;
  out->error_reset = info.error_reset ? 1 : 0;
  return 0;
}

extern "C" size_t cobridge_emcy_describe(const char* family, uint16_t error_code, uint8_t error_register,
                                         const uint8_t* manufacturer, char* buf, size_t buf_len) {
  std::string line;
  try {
    line = cobridge::canopen::describe(family_from_name(family), make(error_code, error_register, manufacturer));
  } catch (...) {  // a C caller cannot take an exception (only bad_alloc is possible)
    line.clear();
  }
  if (buf != nullptr && buf_len > 0) {
    const size_t n = line.size() < buf_len - 1 ? line.size() : buf_len - 1;
    std::memcpy(buf, line.data(), n);
    buf[n] = '\0';
  }
  return line.size();
}
