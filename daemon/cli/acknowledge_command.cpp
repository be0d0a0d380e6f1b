#include "cli/acknowledge_command.hpp"

#include "cli/daemon_route.hpp"
#include "cli/json_value.hpp"

#include <cstdio>

namespace cobridge::cli {

int acknowledge(const AcknowledgeOptions& o) {
  int code = 0;
  const auto doc = ask_daemon(o.control, "acknowledge " + o.device, "acknowledge", o.timeout_ms, o.json, code);
  if (!doc) return code;
  if (!o.json)
    std::printf("%s: its contested configuration may be written again; `cobridge why %s` follows the restore\n",
                o.device.c_str(), o.device.c_str());
  return 0;
}

}  // namespace cobridge::cli
