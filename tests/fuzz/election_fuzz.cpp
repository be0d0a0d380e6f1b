// Fuzz target: the master election (daemon/canopen/master_election.*,
// election_peers.*) against a stranger's frames, as asked: "a
// sequence of frames against two elections: never two masters, never none
// for long". Two gateways (nodes 120 and 121) and two devices (nodes 10 and
// 20, heartbeat 05h every 100 ms, excluded as gateways) run on a simulated
// bus (tests/unit/canopen/election_bus.hpp, 1 ms ticks, fake clock).
// Byte 0 picks which gateway starts first, their priorities (0..1) and
// preempt; then each 4 bytes are one forged frame: its COB-ID (one of the
// election's and heartbeat IDs), two data bytes (from values a claim
// could carry), its length (0..2) and the time before the next one
// (50..617 ms), as CiA 302-2 frames (0x71 claim [priority, node-ID], 0x72,
// 0x73, 0x74, 0x76) and heartbeats (0x700 + node, state byte).
// Invariant (abort on violation): after the pair has settled (2 s), the bus
// is never without a master, nor with two, for 1 s or more.
#include <array>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstdio>

#include "fuzz_input.hpp"
#include "unit/canopen/election_bus.hpp"

using namespace cobridge;
using namespace std::chrono_literals;
using canopen::Duration;
using canopen::election_testing::Bus;

namespace {

constexpr std::array<std::uint8_t, 12> kBytes = {0, 1, 2, 7, 10, 20, 50, 120, 121, 127, 128, 255};
constexpr std::array<std::uint32_t, 9> kIds = {
    canopen::cob::kMasterNodeId,           canopen::cob::kFlyingMasterRequest, canopen::cob::kActiveMasterRequest,
    canopen::cob::kMasterResponse,         canopen::cob::kForceNegotiation,    canopen::cob::kNmtErrorControlBase + 10,
    canopen::cob::kNmtErrorControlBase + 50, canopen::cob::kNmtErrorControlBase + 120,
    canopen::cob::kNmtErrorControlBase + 121};

void fail(const char* what, long long ms) {
  std::fprintf(stderr, "election_fuzz: %s for %lld ms\n", what, ms);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::FuzzInput in(data, size);
  const std::uint8_t setup = in.u8();
  Bus bus;
  bus.exclude({10, 20});
  bus.device_heartbeat(10, 0x05);
  bus.device_heartbeat(20, 0x05);
  const bool flip = (setup & 1) != 0;
  auto& first = bus.add(flip ? 121 : 120, (setup >> 1) & 1, (setup & 4) != 0, 2s);
  auto& second = bus.add(flip ? 120 : 121, (setup >> 3) & 1, (setup & 16) != 0, 2s);
  bus.start(first);
  bus.run(1s);
  bus.start(second);
  bus.run(1s);
  Duration none{}, two{};
  while (!in.empty()) {
    can::Frame f = can::Frame::make(kIds[in.u8() % kIds.size()], {kBytes[in.u8() % kBytes.size()], kBytes[in.u8() % kBytes.size()]});
    const std::uint8_t timing = in.u8();
    f.len = static_cast<std::uint8_t>(timing % 3);
    bus.inject(f);
    bus.run(std::chrono::milliseconds(50 + (timing >> 2) * 9), [&] {
      none = bus.masters() == 0 ? none + 1ms : Duration{};
      two = bus.masters() >= 2 ? two + 1ms : Duration{};
      if (none >= 1s) fail("no master", std::chrono::duration_cast<std::chrono::milliseconds>(none).count());
      if (two >= 1s) fail("two masters", std::chrono::duration_cast<std::chrono::milliseconds>(two).count());
    });
  }
  return 0;
}
