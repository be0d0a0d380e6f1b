#include "control/control_answer.hpp"

#include <cstdio>

#include "base/number_text.hpp"

namespace cobridge::control {
namespace {

const char* nmt_name(canopen::NmtCommand c) {
  switch (c) {
    case canopen::NmtCommand::start: return "start";
    case canopen::NmtCommand::stop: return "stop";
    case canopen::NmtCommand::enter_preop: return "preop";
    case canopen::NmtCommand::reset_node: return "reset";
    case canopen::NmtCommand::reset_comm: return "reset-comm";
  }
  return "?";
}

}  // namespace

std::string error_answer(const Error& error, std::uint32_t abort_code) {
  std::string out = "{\"ok\":false,\"error\":" + error.to_json();
  if (abort_code != 0) {
    char b[16];
    std::snprintf(b, sizeof b, "0x%08X", abort_code);
    out += ",\"abort_code\":\"" + std::string(b) + "\"";
  }
  return out + "}";
}

std::string commission_answer(const std::vector<std::string>& buses, const std::string& message) {
  std::string out = "{\"ok\":true,\"buses\":[";
  for (std::size_t i = 0; i < buses.size(); ++i) out += (i == 0 ? "" : ",") + json_quote(buses[i]);
  out += "]";
  if (!message.empty()) out += ",\"message\":" + json_quote(message);
  return out + "}";
}

std::string remote_answer(const ControlRequest& request, const bus::RemoteResult& result) {
  if (result.error) return error_answer(result.error, result.abort_code);
  const bus::RemoteCommand& c = request.command;
  std::string out = "{\"ok\":true,\"via\":\"daemon\",\"bus\":" + json_quote(request.bus) + ",\"node\":" +
                    std::to_string(c.node);
  switch (c.op) {
    case bus::RemoteOp::sdo_upload: {
      out += ",\"index\":" + std::to_string(c.index) + ",\"sub\":" + std::to_string(c.sub);
      out += ",\"size\":" + std::to_string(result.data.size()) + ",\"hex\":\"" + hex_bytes(result.data) + "\"";
      if (!result.data.empty() && result.data.size() <= 4) {
        std::uint32_t v = 0;
        for (std::size_t i = 0; i < result.data.size(); ++i) v |= std::uint32_t{result.data[i]} << (8 * i);
        out += ",\"value\":" + std::to_string(v);
      }
      break;
    }
    case bus::RemoteOp::sdo_download:
      out += ",\"index\":" + std::to_string(c.index) + ",\"sub\":" + std::to_string(c.sub);
      out += ",\"size\":" + std::to_string(c.data.size());
      break;
    case bus::RemoteOp::nmt:
      out += ",\"command\":\"" + std::string(nmt_name(c.nmt)) + "\"";
      break;
    case bus::RemoteOp::lss: {
      std::uint32_t serial = 0;
      bool stored = false;
      for (const auto& s : c.lss_steps) {
        if (s.kind == bus::LssStep::Kind::switch_selective) serial = s.address.serial;
        if (s.kind == bus::LssStep::Kind::store) stored = true;
      }
      out += ",\"serial\":" + std::to_string(serial) + ",\"stored\":" + (stored ? "true" : "false");
      break;
    }
  }
  return out + "}";
}

}  // namespace cobridge::control
