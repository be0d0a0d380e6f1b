// Fuzz target: the hot path's frame decoder (daemon/pipeline/frame_decoder.*,
// decode_plan.*): decode plans built from fuzzed mapping entries (invalid
// ones must be refused by build_pdo_decode), then any frame on any COB-ID.
// Invariants: a sample names the node its COB-ID says, and only an indexed
// node produces samples.
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "fuzz_input.hpp"
#include "pipeline/device_table.hpp"
#include "pipeline/frame_decoder.hpp"

using namespace cobridge;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::FuzzInput in(data, size);
  pipeline::DeviceTable table;
  const std::uint8_t plans = in.u8() % 4;
  for (std::uint8_t p = 0; p < plans; ++p) {
    pipeline::DecodePlan plan;
    plan.node_id = in.u8() & 0x7F;
    plan.indexed = (in.u8() & 1) != 0;
    plan.device_index = static_cast<std::uint16_t>(in.u32());
    plan.max_age_ms = in.u8();
    for (auto& t : plan.tpdo) {
      std::vector<pipeline::MappedObject> mapping(in.u8() % 10);
      for (auto& m : mapping) m = {in.u32(), (in.u8() & 1) != 0};
      if (pipeline::build_pdo_decode(mapping, t)) t = {};
    }
    plan.active = (in.u8() & 1) != 0;
    table.publish(plan);
  }
  pipeline::FrameDecoder decoder(0, table);
  decoder.set_clocks(static_cast<std::int64_t>(in.u32()), static_cast<std::int64_t>(in.u32()));
  while (!in.empty()) {
    can::Frame f;
    f.id = in.u32() & 0x7FF;
    f.flags = in.u8() & (can::Frame::kFlagRtr | can::Frame::kFlagExtended | can::Frame::kFlagError);
    f.len = in.u8() % 9;
    in.bytes(f.data.data(), f.len);
    f.timestamp_ns = static_cast<std::int64_t>(in.u32());
    pipeline::Sample s;
    if (decoder.decode(f, s) && s.node_id != (f.id & 0x7F) && f.id != 0) std::abort();
    decoder.check_stale(static_cast<std::int64_t>(in.u32()), [](std::uint8_t) {});
  }
  return 0;
}
