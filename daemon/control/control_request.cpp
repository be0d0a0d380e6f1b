#include "control/control_request.hpp"

#include "base/number_text.hpp"

#include <charconv>
#include <vector>

namespace cobridge::control {

namespace {

constexpr const char* kCommands =
    "commands: status, commission [BUS], sdo-read, sdo-write, nmt, lss-set-node-id, capture-now [BUS], "
    "capture-get NAME, acknowledge DEVICE";

// At most 40 bytes of what the client sent, non-printable bytes as '?'.
std::string quoted_input(std::string_view s) {
  std::string out;
  for (const char ch : s.substr(0, 40)) {
    const auto c = static_cast<unsigned char>(ch);
    out += (c >= 0x20 && c < 0x7F) ? ch : '?';
  }
  if (s.size() > 40) out += "...";
  return out;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> words(std::string_view s) {
  std::vector<std::string_view> out;
  while (true) {
    s = trim(s);
    if (s.empty()) break;
    const auto end = s.find_first_of(" \t");
    out.push_back(s.substr(0, end));
    if (end == std::string_view::npos) break;
    s.remove_prefix(end);
  }
  return out;
}

ControlRequest invalid(std::string text) {
  ControlRequest r;
  r.error = Error(Errc::kInvalidArgument, std::move(text));
  return r;
}

ControlRequest parse_sdo(const std::vector<std::string_view>& w, bool write) {
  const std::size_t fixed = write ? 6 : 5;
  const char* usage = write ? "usage: sdo-write BUS NODE INDEX SUB HEXBYTES [TIMEOUT_MS]"
                            : "usage: sdo-read BUS NODE INDEX SUB [TIMEOUT_MS]";
  if (w.size() != fixed && w.size() != fixed + 1) return invalid(usage);
  std::uint64_t node = 0, index = 0, sub = 0, timeout = 500;
  if (!parse_unsigned(w[2], 127, node) || node == 0) return invalid("node \"" + quoted_input(w[2]) + "\" (allowed: 1..127)");
  if (!parse_unsigned(w[3], 0xFFFF, index, true)) return invalid("index \"" + quoted_input(w[3]) + "\" (hex 0..FFFF)");
  if (!parse_unsigned(w[4], 0xFF, sub)) return invalid("sub-index \"" + quoted_input(w[4]) + "\" (0..255)");
  ControlRequest r;
  r.command.op = write ? bus::ServiceOp::sdo_download : bus::ServiceOp::sdo_upload;
  if (write && !parse_hex_bytes(w[5], 1024, r.command.data))
    return invalid("data \"" + quoted_input(w[5]) + "\" (1..1024 bytes as hex digit pairs)");
  if (w.size() == fixed + 1 && (!parse_unsigned(w[fixed], 60000, timeout) || timeout < 10))
    return invalid("timeout \"" + quoted_input(w[fixed]) + "\" (10..60000 ms)");
  r.kind = ControlRequest::Kind::service;
  r.bus = std::string(w[1]);
  r.command.node = static_cast<std::uint8_t>(node);
  r.command.index = static_cast<std::uint16_t>(index);
  r.command.sub = static_cast<std::uint8_t>(sub);
  r.command.sdo_timeout = std::chrono::milliseconds(timeout);
  // Long enough to wait for a reboot and a configuration of the node.
  r.command.deadline = std::chrono::milliseconds(std::max<std::uint64_t>(10000, timeout * 8));
  return r;
}

ControlRequest parse_nmt(const std::vector<std::string_view>& w) {
  if (w.size() != 4) return invalid("usage: nmt BUS start|stop|preop|reset|reset-comm NODE (0 = all)");
  ControlRequest r;
  using canopen::NmtCommand;
  if (w[2] == "start") r.command.nmt = NmtCommand::start;
  else if (w[2] == "stop") r.command.nmt = NmtCommand::stop;
  else if (w[2] == "preop") r.command.nmt = NmtCommand::enter_preop;
  else if (w[2] == "reset") r.command.nmt = NmtCommand::reset_node;
  else if (w[2] == "reset-comm") r.command.nmt = NmtCommand::reset_comm;
  else return invalid("NMT command \"" + quoted_input(w[2]) + "\" (allowed: start, stop, preop, reset, reset-comm)");
  std::uint64_t node = 0;
  if (!parse_unsigned(w[3], 127, node)) return invalid("node \"" + quoted_input(w[3]) + "\" (allowed: 0..127)");
  r.kind = ControlRequest::Kind::service;
  r.bus = std::string(w[1]);
  r.command.op = bus::ServiceOp::nmt;
  r.command.node = static_cast<std::uint8_t>(node);
  return r;
}

ControlRequest parse_lss_set(const std::vector<std::string_view>& w) {
  if (w.size() != 8 && w.size() != 9)
    return invalid("usage: lss-set-node-id BUS VENDOR PRODUCT REVISION SERIAL NODE store|no-store [TIMEOUT_MS]");
  std::uint64_t f[4]{};
  for (std::size_t i = 0; i < 4; ++i) {
    if (!parse_unsigned(w[2 + i], 0xFFFFFFFF, f[i])) return invalid("identity field \"" + quoted_input(w[2 + i]) + "\" (32-bit)");
  }
  std::uint64_t node = 0, timeout = 100;
  if (!parse_unsigned(w[6], 127, node) || node == 0) return invalid("node \"" + quoted_input(w[6]) + "\" (allowed: 1..127)");
  if (w[7] != "store" && w[7] != "no-store") return invalid("\"" + quoted_input(w[7]) + "\" (allowed: store, no-store)");
  if (w.size() == 9 && (!parse_unsigned(w[8], 10000, timeout) || timeout < 10))
    return invalid("timeout \"" + quoted_input(w[8]) + "\" (10..10000 ms)");
  ControlRequest r;
  r.kind = ControlRequest::Kind::service;
  r.bus = std::string(w[1]);
  r.command.op = bus::ServiceOp::lss;
  const canopen::LssAddress a{static_cast<std::uint32_t>(f[0]), static_cast<std::uint32_t>(f[1]),
                              static_cast<std::uint32_t>(f[2]), static_cast<std::uint32_t>(f[3])};
  auto& s = r.command.lss_steps;
  s.push_back({bus::LssStep::Kind::switch_selective, a, 0});
  s.push_back({bus::LssStep::Kind::set_node_id, {}, static_cast<std::uint32_t>(node)});
  if (w[7] == "store") s.push_back({bus::LssStep::Kind::store, {}, 0});
  s.push_back({bus::LssStep::Kind::switch_global, {}, 0});
  r.command.node = static_cast<std::uint8_t>(node);
  r.command.deadline = std::chrono::milliseconds(10000 + timeout * 8);
  return r;
}

ControlRequest parse_capture(const std::vector<std::string_view>& w) {
  ControlRequest r;
  if (w[0] == "capture-now") {
    if (w.size() > 2) return invalid("usage: capture-now [BUS]");
    r.kind = ControlRequest::Kind::capture_now;
    if (w.size() == 2) r.bus = std::string(w[1]);
    return r;
  }
  if (w.size() != 2) return invalid("usage: capture-get NAME");
  r.kind = ControlRequest::Kind::capture_get;
  r.name = std::string(w[1]);
  return r;
}

}  // namespace

ControlRequest parse_control_request(std::string_view line) {
  const auto w = words(line);
  if (w.empty()) return invalid(std::string("empty request (") + kCommands + ")");
  if (w[0] == "status") {
    if (w.size() != 1) return invalid("usage: status");
    ControlRequest r;
    r.kind = ControlRequest::Kind::status;
    return r;
  }
  if (w[0] == "commission") {
    if (w.size() > 2) return invalid("usage: status | commission [BUS]");
    ControlRequest r;
    r.kind = ControlRequest::Kind::commission;
    if (w.size() == 2) r.bus = std::string(w[1]);
    return r;
  }
  if (w[0] == "capture-now" || w[0] == "capture-get") return parse_capture(w);
  if (w[0] == "acknowledge") {
    if (w.size() != 2) return invalid("usage: acknowledge DEVICE");
    ControlRequest r;
    r.kind = ControlRequest::Kind::acknowledge;
    r.name = std::string(w[1]);
    return r;
  }
  if (w[0] == "sdo-read") return parse_sdo(w, false);
  if (w[0] == "sdo-write") return parse_sdo(w, true);
  if (w[0] == "nmt") return parse_nmt(w);
  if (w[0] == "lss-set-node-id") return parse_lss_set(w);
  return invalid("unknown command \"" + quoted_input(w[0]) + "\" (" + kCommands + ")");
}

}  // namespace cobridge::control
