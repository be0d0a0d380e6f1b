#include "cli/sdo_command.hpp"

#include "base/json_writer.hpp"
#include "base/number_text.hpp"
#include "canopen/cob_id.hpp"
#include "canopen/sdo_abort.hpp"
#include "canopen/sdo_client.hpp"
#include "cli/bus_session.hpp"
#include "cli/daemon_route.hpp"

#include <algorithm>
#include <span>

#include <cstdio>
#include <cstdlib>
#include <vector>

namespace cobridge::cli {
namespace {

bool parse_u32(const std::string& s, uint32_t& out) {
  if (s.empty()) return false;
  char* end = nullptr;
  const bool neg = s[0] == '-';
  const unsigned long long v = std::strtoull(s.c_str() + (neg ? 1 : 0), &end, 0);
  if (end == nullptr || *end != '\0' || v > 0xFFFFFFFFull) return false;
  out = neg ? static_cast<uint32_t>(-static_cast<long long>(v)) : static_cast<uint32_t>(v);
  return true;
}

// Runs one started transfer to completion on the interface itself.
// The SDO client of node o.node on a bus session of our own (no daemon).
canopen::SdoClient own_client(BusSession& bus, const SdoOptions& o) {
  return canopen::SdoClient(bus.channel(), static_cast<uint8_t>(o.node),
                            canopen::SdoClient::Config{.timeout = std::chrono::milliseconds(o.timeout_ms)});
}

std::optional<canopen::SdoClient::Result> finish(BusSession& bus, canopen::SdoClient& client, const SdoOptions& o,
                                                 Error& error) {
  bus.run([&](const can::Frame& f, TimePoint now) { client.on_frame(f, now); },
          [&](TimePoint now) { return client.process(now); }, [&] { return client.has_result(); },
          std::chrono::milliseconds(o.timeout_ms * 4 + 1000));
  auto r = client.take_result();
  const std::string where = "node " + std::to_string(o.node) + " on " + o.iface;
  if (!r) {
    error = Error(Errc::kTimeout, "no result", where);
    return std::nullopt;
  }
  if (!r->ok()) {
    const bool silent = r->error == canopen::make_error_code(canopen::SdoAbort::kProtocolTimedOut);
    char text[32];
    std::snprintf(text, sizeof text, "%04X:%u", r->index, r->sub);
    error = Error(silent ? Errc::kTimeout : Errc::kFailed, r->error.message(), where + " object " + text, r->error);
    if (!silent) {
      error.message += " (abort code " + hex(canopen::sdo_abort_wire_code(r->error), 8) + ")";
    }
    return std::nullopt;
  }
  return r;
}

Error check(const SdoOptions& o, uint16_t& index, uint8_t& sub) {
  if (!canopen::cob::valid_node_id(o.node))
    return Error(Errc::kInvalidArgument, "--node " + std::to_string(o.node) + " is not a node-ID (allowed: 1..127)");
  return parse_object(o.object, index, sub);
}

std::string object_words(const SdoOptions& o, uint16_t index, uint8_t sub) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%u %04X %u", o.node, index, sub);
  return buf;
}

int daemon_timeout(const SdoOptions& o) { return static_cast<int>(std::max(10000U, o.timeout_ms * 8)) + 5000; }

// The value as text, up to its first NUL (as a VISIBLE_STRING is read):
// the "string" of the JSON answer with --string.
std::string visible_text(std::span<const uint8_t> d) {
  const std::string text(reinterpret_cast<const char*>(d.data()), d.size());
  return text.substr(0, text.find('\0'));
}

// The JSON answer of a read or write on the bus itself (the daemon's own
// answer has the same fields).
JsonWriter sdo_answer(const SdoOptions& o, uint16_t index, uint8_t sub, std::size_t size) {
  JsonWriter w;
  w.begin_object().field("ok", true).field("bus", o.iface).field("node", o.node).field("index", index);
  w.field("sub", sub).field("size", size);
  return w;
}

void print_read(const SdoOptions& o, uint16_t index, uint8_t sub, std::span<const uint8_t> d, const char* raw_json) {
  if (o.json) {
    if (raw_json != nullptr) {
      // The daemon's answer, with the decoded string added before its closing brace.
      std::string doc(raw_json);
      const std::size_t end = doc.rfind('}');
      if (end != std::string::npos && o.as_string) doc.insert(end, ",\"string\":" + json_quote(visible_text(d)));
      std::printf("%s\n", doc.c_str());
      return;
    }
    uint32_t v = 0;
    for (std::size_t i = 0; i < d.size() && i < 4; ++i) v |= uint32_t{d[i]} << (8 * i);
    JsonWriter w = sdo_answer(o, index, sub, d.size());
    w.field("hex", hex_bytes(d));
    if (!d.empty() && d.size() <= 4) w.field("value", v);
    if (o.as_string) w.field("string", visible_text(d));
    std::printf("%s\n", w.end_object().text().c_str());
  } else if (o.as_string || d.size() > 4) {
    std::printf("%.*s\n", static_cast<int>(d.size()), reinterpret_cast<const char*>(d.data()));
  } else {
    uint32_t v = 0;
    for (std::size_t i = 0; i < d.size(); ++i) v |= uint32_t{d[i]} << (8 * i);
    std::printf("0x%0*X (%u)\n", static_cast<int>(d.size() * 2), v, v);
  }
}

std::vector<uint8_t> hex_to_bytes(const std::string& h) {
  std::vector<uint8_t> out;
  for (std::size_t i = 0; i + 1 < h.size(); i += 2) out.push_back(static_cast<uint8_t>(std::stoul(h.substr(i, 2), nullptr, 16)));
  return out;
}

Error encode_value(const SdoOptions& o, std::vector<uint8_t>& data) {
  if (o.as_string) {
    data.assign(o.value.begin(), o.value.end());
    return {};
  }
  uint32_t v = 0;
  if (!parse_u32(o.value, v)) return Error(Errc::kInvalidArgument, "value '" + o.value + "' is not a 32-bit number");
  const unsigned size = o.size == 0 ? 4 : o.size;
  if (size != 1 && size != 2 && size != 4)
    return Error(Errc::kInvalidArgument, "--size " + std::to_string(size) + " (allowed: 1, 2, 4)");
  if (size < 4 && (v >> (size * 8)) != 0 && (static_cast<int32_t>(v) >= 0))
    return Error(Errc::kInvalidArgument, "value " + o.value + " does not fit " + std::to_string(size) + " byte(s)");
  for (unsigned i = 0; i < size; ++i) data.push_back(static_cast<uint8_t>(v >> (8 * i)));
  return {};
}

}  // namespace

Error parse_object(const std::string& text, uint16_t& index, uint8_t& sub) {
  const std::string where = "object '" + text + "'";
  const auto colon = text.find(':');
  const std::string idx = text.substr(0, colon);
  char* end = nullptr;
  const unsigned long i = std::strtoul(idx.c_str(), &end, 16);
  if (idx.empty() || *end != '\0' || i > 0xFFFF)
    return Error(Errc::kInvalidArgument, "index must be a hex number 0x0000..0xFFFF", where);
  unsigned long s = 0;
  if (colon != std::string::npos) {
    const std::string sb = text.substr(colon + 1);
    s = std::strtoul(sb.c_str(), &end, 0);
    if (sb.empty() || *end != '\0' || s > 0xFF) return Error(Errc::kInvalidArgument, "sub-index must be 0..255", where);
  }
  index = static_cast<uint16_t>(i);
  sub = static_cast<uint8_t>(s);
  return {};
}

int sdo_read(const SdoOptions& o) {
  uint16_t index = 0;
  uint8_t sub = 0;
  if (Error e = check(o, index, sub)) return report_failure("sdo", e, o.json);
  const std::string line = "sdo-read " + o.iface + " " + object_words(o, index, sub) + " " + std::to_string(o.timeout_ms);
  if (auto routed = via_daemon(o.control, o.iface, line, daemon_timeout(o))) {
    if (routed->first) return report_daemon_failure("sdo", *routed, o.json);
    const auto data = hex_to_bytes(routed->second.doc["hex"].str(""));
    print_read(o, index, sub, data, routed->second.line.c_str());
    return 0;
  }
  auto opened = BusSession::open(o.iface);
  if (!opened.ok()) return report_failure("sdo", opened.error(), o.json);
  const std::unique_ptr<BusSession> bus = std::move(opened).value();
  Error err;
  auto client = own_client(*bus, o);
  if (auto ec = client.start_upload(index, sub, canopen::Clock::now()))
    return report_failure("sdo", Error(Errc::kUnavailable, ec.message(), o.iface, ec), o.json);
  auto r = finish(*bus, client, o, err);
  if (!r) return report_failure("sdo", err, o.json);
  print_read(o, index, sub, r->data, nullptr);
  return 0;
}

int sdo_write(const SdoOptions& o) {
  uint16_t index = 0;
  uint8_t sub = 0;
  if (Error e = check(o, index, sub)) return report_failure("sdo", e, o.json);
  std::vector<uint8_t> data;
  if (Error e = encode_value(o, data)) return report_failure("sdo", e, o.json);
  const std::string line = "sdo-write " + o.iface + " " + object_words(o, index, sub) + " " + hex_bytes(data) + " " +
                           std::to_string(o.timeout_ms);
  if (auto routed = via_daemon(o.control, o.iface, line, daemon_timeout(o))) {
    if (routed->first) return report_daemon_failure("sdo", *routed, o.json);
    if (o.json) std::printf("%s\n", routed->second.line.c_str());
    return 0;
  }
  auto opened = BusSession::open(o.iface);
  if (!opened.ok()) return report_failure("sdo", opened.error(), o.json);
  const std::unique_ptr<BusSession> bus = std::move(opened).value();
  Error err;
  auto client = own_client(*bus, o);
  if (auto ec = client.start_download(index, sub, data, canopen::Clock::now()))
    return report_failure("sdo", Error(Errc::kUnavailable, ec.message(), o.iface, ec), o.json);
  if (!finish(*bus, client, o, err)) return report_failure("sdo", err, o.json);
  if (o.json) std::printf("%s\n", sdo_answer(o, index, sub, data.size()).end_object().text().c_str());
  return 0;
}

}  // namespace cobridge::cli
