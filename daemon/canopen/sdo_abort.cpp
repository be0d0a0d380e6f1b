#include "canopen/sdo_abort.hpp"

#include <string>

namespace cobridge::canopen {

namespace {

// Texts follow CiA 301 V4.2 table 22; where a manual words it differently the
// CiA text is kept, because logs are compared against the spec.
std::string_view text_of(uint32_t code) noexcept {
  switch (static_cast<SdoAbort>(code)) {
    case SdoAbort::kToggleBitNotAlternated: return "toggle bit not alternated";
    case SdoAbort::kProtocolTimedOut: return "SDO protocol timed out";
    case SdoAbort::kCommandSpecifierInvalid: return "client/server command specifier not valid or unknown";
    case SdoAbort::kInvalidBlockSize: return "invalid block size (block mode only)";
    case SdoAbort::kInvalidSequenceNumber: return "invalid sequence number (block mode only)";
    case SdoAbort::kCrcError: return "CRC error (block mode only)";
    case SdoAbort::kOutOfMemory: return "out of memory";
    case SdoAbort::kUnsupportedAccess: return "unsupported access to an object";
    case SdoAbort::kWriteOnly: return "attempt to read a write only object";
    case SdoAbort::kReadOnly: return "attempt to write a read only object";
    case SdoAbort::kObjectDoesNotExist: return "object does not exist in the object dictionary";
    case SdoAbort::kObjectCannotBeMapped: return "object cannot be mapped to the PDO";
    case SdoAbort::kPdoLengthExceeded:
      return "the number and length of the objects to be mapped would exceed PDO length";
    case SdoAbort::kParameterIncompatible: return "general parameter incompatibility reason";
    case SdoAbort::kInternalIncompatible: return "general internal incompatibility in the device";
    case SdoAbort::kHardwareError: return "access failed due to a hardware error";
    case SdoAbort::kLengthMismatch:
      return "data type does not match, length of service parameter does not match";
    case SdoAbort::kLengthTooHigh: return "data type does not match, length of service parameter too high";
    case SdoAbort::kLengthTooLow: return "data type does not match, length of service parameter too low";
    case SdoAbort::kSubIndexDoesNotExist: return "sub-index does not exist";
    case SdoAbort::kInvalidValue: return "invalid value for parameter (value range of parameter exceeded)";
    case SdoAbort::kValueTooHigh: return "value of parameter written too high";
    case SdoAbort::kValueTooLow: return "value of parameter written too low";
    case SdoAbort::kMaxLessThanMin: return "maximum value is less than minimum value";
    case SdoAbort::kResourceNotAvailable: return "resource not available: SDO connection";
    case SdoAbort::kGeneralError: return "general error";
    case SdoAbort::kCannotStore: return "data cannot be transferred or stored to the application";
    case SdoAbort::kCannotStoreLocalControl:
      return "data cannot be transferred or stored to the application because of local control";
    case SdoAbort::kCannotStoreDeviceState:
      return "data cannot be transferred or stored to the application because of the present device state";
    case SdoAbort::kNoObjectDictionary:
      return "object dictionary dynamic generation fails or no object dictionary is present";
    case SdoAbort::kNoDataAvailable: return "no data available";
  }
  return {};
}

class SdoAbortCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "sdo_abort"; }
  [[nodiscard]] std::string message(int ev) const override {
    return std::string(sdo_abort_text(static_cast<uint32_t>(ev)));
  }
};

}  // namespace

std::string_view sdo_abort_text(uint32_t code) noexcept {
  const std::string_view t = text_of(code);
  return t.empty() ? std::string_view("unknown abort code") : t;
}

bool is_known_sdo_abort(uint32_t code) noexcept { return !text_of(code).empty(); }

const std::error_category& sdo_abort_category() noexcept {
  static const SdoAbortCategory category;
  return category;
}

std::error_code make_error_code(SdoAbort code) noexcept {
  // All CiA codes are below 2^31, so the int value is the wire value.
  return {static_cast<int>(static_cast<uint32_t>(code)), sdo_abort_category()};
}

std::error_code sdo_abort_error(uint32_t wire_code) noexcept {
  if (wire_code == 0) return make_error_code(SdoAbort::kGeneralError);
  return {static_cast<int>(wire_code), sdo_abort_category()};
}

uint32_t sdo_abort_wire_code(const std::error_code& ec) noexcept {
  if (ec && ec.category() == sdo_abort_category()) return static_cast<uint32_t>(ec.value());
  return static_cast<uint32_t>(SdoAbort::kGeneralError);
}

}  // namespace cobridge::canopen
