// EDS errors: the error category of EdsErrc and EdsError's text.
#include "device/eds.hpp"

#include <string>

namespace cobridge::device {

namespace {
class EdsCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "cobridge.eds"; }
  std::string message(int ev) const override {
    switch (static_cast<EdsErrc>(ev)) {
      case EdsErrc::kIo: return "cannot read file";
      case EdsErrc::kSyntax: return "syntax error";
      case EdsErrc::kBinaryData: return "binary data";
      case EdsErrc::kDuplicateSection: return "duplicate section";
      case EdsErrc::kDuplicateKey: return "duplicate key";
      case EdsErrc::kMissingSection: return "missing section";
      case EdsErrc::kUnlistedObject: return "object not in any object list";
      case EdsErrc::kSubWithoutParent: return "sub-object without parent object";
      case EdsErrc::kMissingKey: return "missing key";
      case EdsErrc::kBadNumber: return "malformed number";
      case EdsErrc::kBadDataType: return "not a CiA 301 data type";
      case EdsErrc::kBadObjectType: return "not a CiA 306 object type";
      case EdsErrc::kBadAccessType: return "not a CiA 306 access type";
      case EdsErrc::kOutOfRange: return "value out of range";
      case EdsErrc::kInconsistent: return "inconsistent description";
      case EdsErrc::kUnsupported: return "unsupported EDS feature";
      case EdsErrc::kDuplicateIdentity: return "duplicate device identity";
      case EdsErrc::kTooManyErrors: return "too many errors";
    }
    return "unknown EDS error";
  }
};
}  // namespace

const std::error_category& eds_category() noexcept {
  static const EdsCategory category;
  return category;
}

std::error_code make_error_code(EdsErrc e) noexcept { return {static_cast<int>(e), eds_category()}; }

std::string EdsError::where() const {
  std::string s = file;
  if (line != 0) {
    s += ':';
    s += std::to_string(line);
    if (column != 0) {
      s += ':';
      s += std::to_string(column);
    }
  }
  return s;
}

std::string EdsError::to_string() const { return where() + ": " + message; }

Error to_error(const EdsError& error) {
  Errc kind = Errc::kInvalidArgument;
  if (error.code == EdsErrc::kIo) kind = error.message == "cannot open the file" ? Errc::kNotFound : Errc::kFailed;
  return Error(kind, error.message, error.where(), make_error_code(error.code));
}

}  // namespace cobridge::device
