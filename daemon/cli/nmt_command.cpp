#include "cli/nmt_command.hpp"

#include "canopen/cob_id.hpp"
#include "canopen/nmt.hpp"
#include "cli/bus_session.hpp"

#include <cstdio>
#include <cstdlib>

namespace cobridge::cli {

int nmt_send(const NmtOptions& o) {
  using canopen::NmtCommand;
  NmtCommand cmd;
  if (o.command == "start") cmd = NmtCommand::start;
  else if (o.command == "stop") cmd = NmtCommand::stop;
  else if (o.command == "preop") cmd = NmtCommand::enter_preop;
  else if (o.command == "reset") cmd = NmtCommand::reset_node;
  else if (o.command == "reset-comm") cmd = NmtCommand::reset_comm;
  else {
    std::fprintf(stderr, "cobridge: nmt: unknown command '%s' (allowed: start, stop, preop, reset, reset-comm)\n",
                 o.command.c_str());
    return 2;
  }
  unsigned node = 0;
  if (o.node != "all") {
    char* end = nullptr;
    node = static_cast<unsigned>(std::strtoul(o.node.c_str(), &end, 0));
    if (o.node.empty() || *end != '\0' || !canopen::cob::valid_node_id(node)) {
      std::fprintf(stderr, "cobridge: nmt: node '%s' (allowed: 1..127 or all)\n", o.node.c_str());
      return 2;
    }
  }
  std::string error;
  auto bus = BusSession::open(o.iface, error);
  if (!bus) {
    std::fprintf(stderr, "cobridge: nmt: %s\n", error.c_str());
    return 1;
  }
  if (!bus->channel().send(canopen::make_nmt(cmd, static_cast<uint8_t>(node)))) {
    std::fprintf(stderr, "cobridge: nmt: %s: could not send the frame\n", o.iface.c_str());
    return 1;
  }
  return 0;
}

}  // namespace cobridge::cli
