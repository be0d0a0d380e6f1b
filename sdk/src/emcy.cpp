// The SDK's C face of device/emcy_meaning: the family modules' own EMCY
// tables (daemon/families) and the CiA 301 table (canopen/emcy), compiled
// into libcobridge_sdk from the same sources as the daemon (no second copy).
#include <cobridge/emcy.h>

#include <array>
#include <cstring>
#include <string>
#include <string_view>

#include "device/emcy_meaning.hpp"
#include "families/family.hpp"

namespace {

namespace fam = cobridge::families;
using fam::EmcyLevel;

static_assert(static_cast<int>(EmcyLevel::info) == COBRIDGE_EMCY_LEVEL_INFO &&
                  static_cast<int>(EmcyLevel::warn) == COBRIDGE_EMCY_LEVEL_WARN &&
                  static_cast<int>(EmcyLevel::error) == COBRIDGE_EMCY_LEVEL_ERROR &&
                  static_cast<int>(EmcyLevel::hard) == COBRIDGE_EMCY_LEVEL_HARD,
              "cobridge/emcy.h levels must equal families::EmcyLevel");

// An EDS [Cobridge] Family name, with '-' or '_' (families::find_family
// knows the '-' spelling); nullptr for NULL or an unknown name.
const fam::Family* family_from_name(const char* family) noexcept {
  if (family == nullptr) return nullptr;
  std::array<char, 64> dashed{};
  const std::size_t n = ::strnlen(family, dashed.size());
  if (n == dashed.size()) return nullptr;  // longer than any family name
  for (std::size_t i = 0; i < n; ++i) dashed[i] = family[i] == '_' ? '-' : family[i];
  return fam::find_family(std::string_view(dashed.data(), n));
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
  const auto info =
      cobridge::device::classify_emcy(family_from_name(family), make(error_code, error_register, manufacturer));
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
    line = cobridge::device::describe_emcy(family_from_name(family), make(error_code, error_register, manufacturer));
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
