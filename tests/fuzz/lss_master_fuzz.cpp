// Fuzz target: the LSS master's response handling (daemon/canopen/lss_master.*,
// CiA 305): any operation (Fastscan with known fields, Slowscan, switch
// selective, configure, store, inquire, identify) under fuzzed 0x7E4 answers
// and time steps, with waits learnt from the answers (AnswerTiming).
// Invariants: an operation always ends (busy() turns false within bounded
// time) and its result is taken at most once.
#include <cstdint>
#include <cstdlib>

#include "can/frame_sink.hpp"
#include "canopen/lss_master.hpp"
#include "fuzz_input.hpp"

using namespace cobridge;

namespace {

struct Sink final : can::FrameSink {
  bool send(const can::Frame& f) noexcept override {
    if (f.id != 0x7E5) std::abort();  // the master only speaks on its own COB-ID
    return true;
  }
};

void start(canopen::LssMaster& m, fuzz::FuzzInput& in, canopen::TimePoint now) {
  const canopen::LssAddress a{in.u32(), in.u32(), in.u32(), in.u32()};
  switch (in.u8() % 7) {
    case 0: {
      canopen::LssMaster::FastscanKnown k;
      if ((in.u8() & 1) != 0) k.vendor = a.vendor;
      if ((in.u8() & 1) != 0) k.serial = a.serial;
      (void)m.fastscan(now, k);
      break;
    }
    case 1: (void)m.slowscan(canopen::LssRange{a.vendor, a.product, 0, a.revision, 0, a.serial}, now); break;
    case 2: (void)m.switch_state_selective(a, now); break;
    case 3: (void)m.configure_node_id(in.u8(), now); break;
    case 4: (void)m.store_configuration(now); break;
    case 5: (void)m.inquire(static_cast<canopen::LssCs>(0x5A + in.u8() % 6), now); break;
    default: (void)m.identify_non_configured(now); break;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::FuzzInput in(data, size);
  Sink sink;
  canopen::LssMaster master(sink, canopen::LssMasterConfig{std::chrono::milliseconds(100), std::chrono::milliseconds(2)});
  canopen::TimePoint now{std::chrono::seconds(100)};
  while (!in.empty()) {
    if (!master.busy()) start(master, in, now);
    can::Frame f;
    f.id = (in.u8() & 7) == 0 ? in.u32() & 0x7FF : 0x7E4;
    f.len = (in.u8() & 7) == 0 ? in.u8() % 9 : 8;
    in.bytes(f.data.data(), f.len);
    now += std::chrono::microseconds(in.u8() * 50);
    (void)master.on_frame(f, now);
    now = std::max(now, std::min(master.process(now), now + std::chrono::seconds(1)));
    (void)master.take_result();
  }
  // Without answers every operation ends: at most 2 x 128 search steps + a few.
  for (int i = 0; i < 400 && master.busy(); ++i) now = master.process(now);
  if (master.busy()) std::abort();
  return 0;
}
