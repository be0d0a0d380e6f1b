// Fuzz target: the CiA 306 EDS parser (daemon/device/eds.*). Any text gives a
// description or errors with file and line, never a crash or UB.
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "device/eds.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const cobridge::device::EdsResult r = cobridge::device::parse_eds(text, "fuzz.eds");
  if (!r.ok() && r.errors.empty()) std::abort();
  if (r.ok() && !r.description) std::abort();
  return 0;
}
