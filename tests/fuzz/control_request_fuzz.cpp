// Fuzz target: the control socket's request parser
// (daemon/control/control_request.*). Any line gives a request or an error
// text of printable ASCII (it is echoed to the client inside JSON).
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "control/control_request.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view line(reinterpret_cast<const char*>(data), size);
  const auto r = cobridge::control::parse_control_request(line);
  using Kind = cobridge::control::ControlRequest::Kind;
  if ((r.kind == Kind::invalid) == r.error.ok()) std::abort();
  for (const char c : r.error.message)
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7F) std::abort();
  return 0;
}
