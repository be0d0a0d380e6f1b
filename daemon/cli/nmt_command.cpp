#include "cli/nmt_command.hpp"

#include "base/json_writer.hpp"
#include "canopen/cob_id.hpp"
#include "canopen/nmt.hpp"
#include "cli/bus_session.hpp"
#include "cli/daemon_route.hpp"

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
  else
    return report_failure("nmt", Error(Errc::kInvalidArgument, "unknown command '" + o.command +
                                                                   "' (allowed: start, stop, preop, reset, reset-comm)"),
                          o.json);
  unsigned node = 0;
  if (o.node != "all") {
    char* end = nullptr;
    node = static_cast<unsigned>(std::strtoul(o.node.c_str(), &end, 0));
    if (o.node.empty() || *end != '\0' || !canopen::cob::valid_node_id(node))
      return report_failure("nmt", Error(Errc::kInvalidArgument, "node '" + o.node + "' (allowed: 1..127 or all)"), o.json);
  }
  const std::string line = "nmt " + o.iface + " " + o.command + " " + std::to_string(node);
  if (auto routed = via_daemon(o.control, o.iface, line, 5000)) {
    if (routed->first) return report_daemon_failure("nmt", *routed, o.json);
    if (o.json) std::printf("%s\n", routed->second.line.c_str());
    return 0;
  }
  auto opened = BusSession::open(o.iface);
  if (!opened.ok()) return report_failure("nmt", opened.error(), o.json);
  const std::unique_ptr<BusSession> bus = std::move(opened).value();
  if (!bus->channel().send(canopen::make_nmt(cmd, static_cast<uint8_t>(node))))
    return report_failure("nmt", Error(Errc::kUnavailable, "could not send the frame", o.iface), o.json);
  if (o.json) {
    JsonWriter w;
    w.begin_object().field("ok", true).field("bus", o.iface).field("node", node).field("command", o.command);
    std::printf("%s\n", w.end_object().text().c_str());
  }
  return 0;
}

}  // namespace cobridge::cli
