#include "bus/remote/remote_command.hpp"

namespace cobridge::bus {

const char* to_string(RemoteOp op) noexcept {
  switch (op) {
    case RemoteOp::sdo_upload: return "SDO upload";
    case RemoteOp::sdo_download: return "SDO download";
    case RemoteOp::nmt: return "NMT";
    case RemoteOp::lss: return "LSS";
  }
  return "?";
}

}  // namespace cobridge::bus
