// Fuzz target: the SDO observer (daemon/canopen/sdo_observer.*), which
// follows another client's SDO downloads on the bus (CiA 301 §7.2.4.3.3..6
// expedited and segmented, §7.2.4.3.9..14 block). The bytes are a sequence
// of frames, 9 bytes each: a selector (bits 0-1 the node: 1, 2, 127 or 0;
// bits 2-3 request 0x600+n, response 0x580+n (twice as likely), or a frame
// the observer must ignore: RTR, 29-bit, shorter than 8 bytes, another
// COB-ID; bits 4-7 time advanced before it, in 100 ms) and 8 data bytes.
// Invariants (abort on violation), as sdo_observer.hpp promises:
//   * only a server's confirmation reports a write: an 8-byte 11-bit data
//     frame on 0x581..0x5FF, and the write names that node;
//   * a confirmation later than kAnswerWithin after the client's latest
//     request to the node reports nothing;
//   * the write names an index:sub some initiate request to the node named;
//     `size` is the first min(total, kKeptBytes) bytes;
//   * an expedited write (confirmed by scs 3) is the latest request's value:
//     its index:sub, 4 - n bytes (n only when s is set), those bytes;
//   * a write is reported once: the same confirmation again reports nothing.
#include <array>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <set>

#include "can/frame.hpp"
#include "canopen/sdo_observer.hpp"
#include "fuzz_input.hpp"

using namespace cobridge;
using canopen::ObservedWrite;
using canopen::SdoObserver;

namespace {

struct Model {
  std::array<canopen::TimePoint, 128> last_request{};
  std::array<can::Frame, 128> latest{};           // the latest request frame to each node
  std::array<std::set<std::uint32_t>, 128> named;  // index << 8 | sub of initiate-looking requests
};

std::uint32_t object_of(const can::Frame& f) {
  return static_cast<std::uint32_t>(f.data[2]) << 16 | static_cast<std::uint32_t>(f.data[1]) << 8 | f.data[3];
}

void note_request(Model& m, std::uint8_t node, const can::Frame& f, canopen::TimePoint now) {
  m.last_request[node] = now;
  m.latest[node] = f;
  const std::uint8_t ccs = f.data[0] >> 5;
  if (ccs == 1 || (ccs == 6 && (f.data[0] & 1) == 0)) m.named[node].insert(object_of(f));
}

void check_expedited(const Model& m, const ObservedWrite& w) {
  const can::Frame& req = m.latest[w.node];
  const std::uint8_t b0 = req.data[0];
  if ((b0 >> 5) != 1 || (b0 & 0x02) == 0 || object_of(req) != (std::uint32_t{w.index} << 8 | w.sub)) std::abort();
  const std::uint32_t n = (b0 & 0x01) != 0 ? (b0 >> 2) & 0x03 : 0;
  if (w.total != 4 - n || w.size != w.total) std::abort();
  for (std::size_t i = 0; i < w.size; ++i)
    if (w.data[i] != req.data[4 + i]) std::abort();
}

void check_write(const Model& m, const can::Frame& f, const ObservedWrite& w, canopen::TimePoint now) {
  if (f.len != 8 || f.flags != 0 || f.id <= 0x580 || f.id > 0x5FF || w.node != f.id - 0x580) std::abort();
  if (now - m.last_request[w.node] > SdoObserver::kAnswerWithin) std::abort();
  if (m.named[w.node].count(std::uint32_t{w.index} << 8 | w.sub) == 0) std::abort();
  if (w.size != std::min<std::uint32_t>(w.total, SdoObserver::kKeptBytes)) std::abort();
  if ((f.data[0] >> 5) == 3) check_expedited(m, w);
}

// A frame the observer must not take for an SDO: RTR, 29-bit, short, or
// another service's COB-ID.
void make_foreign(can::Frame& f, std::uint8_t node) {
  switch (f.data[7] & 3) {
    case 0: f.flags = can::Frame::kFlagRtr; break;
    case 1: f.flags = can::Frame::kFlagExtended; break;
    case 2: f.len = f.data[6] % 8; break;
    default: f.id = (f.data[6] & 1) != 0 ? 0x700u + node : 0x180u + node; return;
  }
  f.id = ((f.data[6] & 1) != 0 ? 0x600u : 0x580u) + node;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static constexpr std::array<std::uint8_t, 4> kNodes{1, 2, 127, 0};
  fuzz::FuzzInput in(data, size);
  SdoObserver observer;
  Model model;
  canopen::TimePoint now{std::chrono::seconds(100)};
  while (!in.empty()) {
    const std::uint8_t sel = in.u8();
    const std::uint8_t node = kNodes[sel & 3];
    const unsigned kind = (sel >> 2) & 3;
    now += std::chrono::milliseconds(100 * (sel >> 4));
    can::Frame f;
    f.len = 8;
    in.bytes(f.data.data(), 8);
    f.id = (kind == 0 ? 0x600u : 0x580u) + node;
    if (kind == 3) make_foreign(f, node);
    if (kind == 0 && node != 0) note_request(model, node, f, now);
    const auto w = observer.on_frame(f, now);
    if (!w) continue;
    check_write(model, f, *w, now);
    if (observer.on_frame(f, now)) std::abort();
  }
  return 0;
}
