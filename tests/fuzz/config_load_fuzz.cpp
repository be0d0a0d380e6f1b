// Fuzz target: the configuration loader (daemon/config/load.*), TOML text to
// a Config or a list of file:line:col diagnostics. Any text must give one of
// the two, never a crash, hang or UB (the
// nesting limit included).
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "config/load.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const cobridge::config::LoadResult r = cobridge::config::load_string(text, "fuzz.toml", "/nonexistent");
  if (!r.ok() && r.diagnostics().empty()) std::abort();  // an error must say what is wrong
  return 0;
}
