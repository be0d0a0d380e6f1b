// Fuzz target: the SDO client's response handling (daemon/canopen/sdo_client.*,
// CiA 301 §7.2.4): uploads and downloads (expedited and segmented) are
// started, then fuzzed frames arrive on the response COB-ID (and others)
// while time advances. Invariants: the client always ends idle or with a
// result, an upload's data never exceeds the buffer, and it only ever sends on
// its own request COB-ID.
#include <array>
#include <cstdint>
#include <cstdlib>

#include "can/frame_sink.hpp"
#include "canopen/sdo_client.hpp"
#include "fuzz_input.hpp"

using namespace cobridge;

namespace {

struct Sink final : can::FrameSink {
  bool refuse = false;
  bool send(const can::Frame& f) noexcept override {
    if (f.id != 0x600u + 5) std::abort();  // node 5's request COB-ID only
    return !refuse;
  }
};

void start(canopen::SdoClient& c, fuzz::FuzzInput& in, canopen::TimePoint now) {
  const std::uint16_t index = static_cast<std::uint16_t>(in.u32());
  const std::uint8_t sub = in.u8();
  if ((in.u8() & 1) != 0) {
    (void)c.start_upload(index, sub, now);
    return;
  }
  std::array<std::uint8_t, 64> payload{};
  const std::size_t n = 1 + in.u8() % payload.size();
  in.bytes(payload.data(), n);
  (void)c.start_download(index, sub, std::span<const std::uint8_t>(payload.data(), n), now);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::FuzzInput in(data, size);
  Sink sink;
  canopen::SdoClientConfig cfg;
  cfg.retries = in.u8() % 3;
  cfg.buffer_size = 256;
  canopen::SdoClient client(sink, 5, cfg);
  canopen::TimePoint now{std::chrono::seconds(100)};
  while (!in.empty()) {
    const std::uint8_t op = in.u8() % 8;
    if (op == 0 && !client.busy()) start(client, in, now);
    if (op == 1) now += std::chrono::milliseconds(in.u8() * 4);
    if (op == 2) sink.refuse = !sink.refuse;
    if (op == 3) client.abort(canopen::SdoAbort::kGeneralError);
    if (op >= 4) {
      can::Frame f;
      f.id = (in.u8() & 3) == 0 ? in.u32() & 0x7FF : 0x580u + 5;
      f.len = (in.u8() & 7) == 0 ? in.u8() % 9 : 8;
      in.bytes(f.data.data(), f.len);
      (void)client.on_frame(f, now);
    }
    (void)client.process(now);
    if (const auto r = client.take_result(); r && r->data.size() > cfg.buffer_size) std::abort();
  }
  return 0;
}
