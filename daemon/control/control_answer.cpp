#include "control/control_answer.hpp"

#include "base/json_writer.hpp"
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
  JsonWriter w;
  w.begin_object().field("ok", false).key("error").raw(error.to_json());
  if (abort_code != 0) w.field("abort_code", hex(abort_code, 8));
  return w.end_object().take();
}

std::string commission_answer(const std::vector<std::string>& buses, const std::string& message) {
  JsonWriter w;
  w.begin_object().field("ok", true).key("buses").begin_array();
  for (const auto& b : buses) w.value(b);
  w.end_array();
  if (!message.empty()) w.field("message", message);
  return w.end_object().take();
}

std::string capture_answer(const std::string& name, const std::string& text) {
  JsonWriter w;
  return w.begin_object().field("ok", true).field("name", name).field("text", text).end_object().take();
}

namespace {

// The value of an upload of up to 4 bytes (CiA 301 §7.4.8.2: little endian).
std::uint32_t little_endian(const std::vector<std::uint8_t>& data) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < data.size(); ++i) v |= std::uint32_t{data[i]} << (8 * i);
  return v;
}

void write_lss(JsonWriter& w, const bus::ServiceRequest& c) {
  std::uint32_t serial = 0;
  bool stored = false;
  for (const auto& s : c.lss_steps) {
    if (s.kind == bus::LssStep::Kind::switch_selective) serial = s.address.serial;
    if (s.kind == bus::LssStep::Kind::store) stored = true;
  }
  w.field("serial", serial).field("stored", stored);
}

}  // namespace

std::string service_answer(const ControlRequest& request, const bus::ServiceResult& result) {
  if (result.error) return error_answer(result.error, result.abort_code);
  const bus::ServiceRequest& c = request.command;
  JsonWriter w;
  w.begin_object().field("ok", true).field("via", "daemon").field("bus", request.bus).field("node", c.node);
  switch (c.op) {
    case bus::ServiceOp::sdo_upload:
      w.field("index", c.index).field("sub", c.sub).field("size", result.data.size());
      w.field("hex", hex_bytes(result.data));
      if (!result.data.empty() && result.data.size() <= 4) w.field("value", little_endian(result.data));
      break;
    case bus::ServiceOp::sdo_download:
      w.field("index", c.index).field("sub", c.sub).field("size", c.data.size());
      break;
    case bus::ServiceOp::nmt:
      w.field("command", nmt_name(c.nmt));
      break;
    case bus::ServiceOp::lss:
      write_lss(w, c);
      break;
  }
  return w.end_object().take();
}

}  // namespace cobridge::control
