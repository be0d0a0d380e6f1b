#include "cli/sdo_command.hpp"

#include "canopen/cob_id.hpp"
#include "canopen/sdo_abort.hpp"
#include "canopen/sdo_client.hpp"
#include "cli/bus_session.hpp"

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

// Runs one started transfer to completion; prints the error and returns
// nullopt on failure.
std::optional<canopen::SdoClient::Result> finish(BusSession& bus, canopen::SdoClient& client,
                                                 const SdoOptions& o) {
  bus.run([&](const can::Frame& f, TimePoint now) { client.on_frame(f, now); },
          [&](TimePoint now) { return client.process(now); }, [&] { return client.has_result(); },
          std::chrono::milliseconds(o.timeout_ms * 4 + 1000));
  auto r = client.take_result();
  if (!r) {
    std::fprintf(stderr, "cobridge: sdo: no result from node %u on %s\n", o.node, o.iface.c_str());
    return std::nullopt;
  }
  if (!r->ok()) {
    std::fprintf(stderr, "cobridge: sdo: node %u %04X:%u: %s (0x%08X)\n", o.node, r->index, r->sub,
                 r->error.message().c_str(), canopen::sdo_abort_wire_code(r->error));
    return std::nullopt;
  }
  return r;
}

bool setup(const SdoOptions& o, uint16_t& index, uint8_t& sub, std::unique_ptr<BusSession>& bus) {
  std::string error;
  if (!canopen::cob::valid_node_id(o.node)) {
    std::fprintf(stderr, "cobridge: sdo: --node %u is not a node-ID (allowed: 1..127)\n", o.node);
    return false;
  }
  if (!parse_object(o.object, index, sub, error)) {
    std::fprintf(stderr, "cobridge: sdo: object '%s': %s\n", o.object.c_str(), error.c_str());
    return false;
  }
  bus = BusSession::open(o.iface, error);
  if (!bus) {
    std::fprintf(stderr, "cobridge: sdo: %s\n", error.c_str());
    return false;
  }
  return true;
}

}  // namespace

bool parse_object(const std::string& text, uint16_t& index, uint8_t& sub, std::string& error) {
  const auto colon = text.find(':');
  const std::string idx = text.substr(0, colon);
  char* end = nullptr;
  const unsigned long i = std::strtoul(idx.c_str(), &end, 16);
  if (idx.empty() || *end != '\0' || i > 0xFFFF) {
    error = "index must be a hex number 0x0000..0xFFFF";
    return false;
  }
  unsigned long s = 0;
  if (colon != std::string::npos) {
    const std::string sb = text.substr(colon + 1);
    s = std::strtoul(sb.c_str(), &end, 0);
    if (sb.empty() || *end != '\0' || s > 0xFF) {
      error = "sub-index must be 0..255";
      return false;
    }
  }
  index = static_cast<uint16_t>(i);
  sub = static_cast<uint8_t>(s);
  return true;
}

int sdo_read(const SdoOptions& o) {
  uint16_t index = 0;
  uint8_t sub = 0;
  std::unique_ptr<BusSession> bus;
  if (!setup(o, index, sub, bus)) return 2;
  canopen::SdoClient client(bus->channel(), static_cast<uint8_t>(o.node),
                            canopen::SdoClient::Config{.timeout = std::chrono::milliseconds(o.timeout_ms)});
  if (auto ec = client.start_upload(index, sub, canopen::Clock::now())) {
    std::fprintf(stderr, "cobridge: sdo: %s\n", ec.message().c_str());
    return 1;
  }
  auto r = finish(*bus, client, o);
  if (!r) return 1;
  const auto& d = r->data;
  if (o.json) {
    std::printf("{\"node\":%u,\"index\":%u,\"sub\":%u,\"size\":%zu,\"value\":%u,\"hex\":\"", o.node,
                index, sub, d.size(), d.size() <= 4 ? r->as_u32() : 0u);
    for (uint8_t b : d) std::printf("%02X", b);
    std::printf("\"}\n");
  } else if (o.as_string || d.size() > 4) {
    std::printf("%.*s\n", static_cast<int>(d.size()), reinterpret_cast<const char*>(d.data()));
  } else {
    std::printf("0x%0*X (%u)\n", static_cast<int>(d.size() * 2), r->as_u32(), r->as_u32());
  }
  return 0;
}

int sdo_write(const SdoOptions& o) {
  uint16_t index = 0;
  uint8_t sub = 0;
  std::unique_ptr<BusSession> bus;
  if (!setup(o, index, sub, bus)) return 2;
  std::vector<uint8_t> data;
  if (o.as_string) {
    data.assign(o.value.begin(), o.value.end());
  } else {
    uint32_t v = 0;
    if (!parse_u32(o.value, v)) {
      std::fprintf(stderr, "cobridge: sdo: value '%s' is not a 32-bit number\n", o.value.c_str());
      return 2;
    }
    const unsigned size = o.size == 0 ? 4 : o.size;
    if (size != 1 && size != 2 && size != 4) {
      std::fprintf(stderr, "cobridge: sdo: --size %u (allowed: 1, 2, 4)\n", size);
      return 2;
    }
    if (size < 4 && (v >> (size * 8)) != 0 && (static_cast<int32_t>(v) >= 0)) {
      std::fprintf(stderr, "cobridge: sdo: value 0x%X does not fit %u byte(s)\n", v, size);
      return 2;
    }
    for (unsigned i = 0; i < size; ++i) data.push_back(static_cast<uint8_t>(v >> (8 * i)));
  }
  canopen::SdoClient client(bus->channel(), static_cast<uint8_t>(o.node),
                            canopen::SdoClient::Config{.timeout = std::chrono::milliseconds(o.timeout_ms)});
  if (auto ec = client.start_download(index, sub, data, canopen::Clock::now())) {
    std::fprintf(stderr, "cobridge: sdo: %s\n", ec.message().c_str());
    return 1;
  }
  if (!finish(*bus, client, o)) return 1;
  if (o.json) std::printf("{\"node\":%u,\"index\":%u,\"sub\":%u,\"ok\":true}\n", o.node, index, sub);
  return 0;
}

}  // namespace cobridge::cli
