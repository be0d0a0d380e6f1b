#include "write_policy.hpp"

#include "dcmd_request.hpp"

#include <cobridge/plugin.h>

namespace cobridge::mqtt {

std::string WritePolicy::refusal(std::string_view name, std::uint8_t kind) const {
  if (!enabled) return "writes are disabled ([outputs.mqtt] writes_enabled = false)";
  if (allow.empty()) return {};
  for (const WriteRule& r : allow)
    if ((r.device == "*" || r.device == name) && (r.kind == 0 || r.kind == kind)) return {};
  return std::string(command_name(kind)) + " on device " + std::string(name) +
         " is not in [outputs.mqtt] write_allow";
}

std::string parse_write_rule(std::string_view entry, WriteRule& out) {
  const std::size_t colon = entry.find(':');
  const std::string_view device = entry.substr(0, colon);
  if (device.empty()) return "names no device (\"<device>\", \"<device>:<command>\" or \"*:<command>\")";
  out.device = std::string(device);
  out.kind = 0;
  if (colon == std::string_view::npos) {
    if (device == "*") return "\"*\" alone: leave write_allow empty to allow every device and command";
    return {};
  }
  const std::string_view cmd = entry.substr(colon + 1);
  static constexpr std::uint8_t kKinds[] = {COBRIDGE_COMMAND_PRESET, COBRIDGE_COMMAND_NMT_RESET,
                                            COBRIDGE_COMMAND_STORE};
  for (const std::uint8_t k : kKinds)
    if (cmd == command_name(k)) out.kind = k;
  if (out.kind == 0) return "names the command '" + std::string(cmd) + "' (preset, nmt_reset or store)";
  return {};
}

}  // namespace cobridge::mqtt
