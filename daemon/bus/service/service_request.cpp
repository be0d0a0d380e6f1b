#include "bus/service/service_request.hpp"

namespace cobridge::bus {

const char* to_string(ServiceOp op) noexcept {
  switch (op) {
    case ServiceOp::sdo_upload: return "SDO upload";
    case ServiceOp::sdo_download: return "SDO download";
    case ServiceOp::nmt: return "NMT";
    case ServiceOp::lss: return "LSS";
  }
  return "?";
}

}  // namespace cobridge::bus
