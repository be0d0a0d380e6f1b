#include "gateway/control_request.hpp"

#include <vector>

namespace cobridge::gateway {

namespace {

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

}  // namespace

ControlRequest parse_control_request(std::string_view line) {
  const auto w = words(line);
  ControlRequest r;
  if (w.empty()) {
    r.error = "empty request (commands: status, commission [BUS])";
  } else if (w[0] == "status" && w.size() == 1) {
    r.kind = ControlRequest::Kind::status;
  } else if (w[0] == "commission" && w.size() <= 2) {
    r.kind = ControlRequest::Kind::commission;
    if (w.size() == 2) r.bus = std::string(w[1]);
  } else if (w[0] == "status" || w[0] == "commission") {
    r.error = "usage: status | commission [BUS]";
  } else {
    r.error = "unknown command \"" + quoted_input(w[0]) + "\" (commands: status, commission [BUS])";
  }
  return r;
}

}  // namespace cobridge::gateway
