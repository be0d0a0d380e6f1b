#include "pipeline/decode_plan.hpp"

namespace cobridge::pipeline {

Signal signal_of(std::uint16_t index, std::uint8_t sub) noexcept {
  switch (index) {
    case 0x6004: return Signal::position;
    case 0x600C: return Signal::position;  // multiturn raw position (E§4.2) when mapped instead
    case 0x6020: return sub == 1 ? Signal::position : Signal::none;
    case 0x6030: return sub == 1 ? Signal::speed : Signal::none;
    case 0x6300: return sub == 1 ? Signal::cam : Signal::none;
    case 0x6400: return sub == 1 ? Signal::work_area : Signal::none;
    case 0x6503: return Signal::alarms;
    case 0x6505: return Signal::warnings;
    case 0x2002: return Signal::temperature;
    case 0x2003: return Signal::voltage;
    default: return Signal::none;
  }
}

Error build_pdo_decode(std::span<const MappedObject> mapping, PdoDecode& out) {
  out = PdoDecode{};
  unsigned offset = 0;
  if (mapping.size() > PdoDecode::kMaxFields) return Error(Errc::kUnsupported, "more than 8 mapped objects");
  for (std::size_t i = 0; i < mapping.size(); ++i) {
    const std::uint32_t e = mapping[i].entry;
    const auto index = static_cast<std::uint16_t>(e >> 16);
    const auto sub = static_cast<std::uint8_t>(e >> 8);
    const auto bits = static_cast<std::uint8_t>(e);
    if (bits == 0 || bits > 32) {
      return Error(Errc::kUnsupported,
                   "entry " + std::to_string(i + 1) + ": length " + std::to_string(bits) + " bits (allowed 1..32)");
    }
    if (offset + bits > 64) return Error(Errc::kUnsupported, "mapping longer than 64 bits");
    out.fields[i] = FieldDecode{static_cast<std::uint8_t>(offset), bits, mapping[i].is_signed, signal_of(index, sub)};
    offset += bits;
  }
  out.count = static_cast<std::uint8_t>(mapping.size());
  out.frame_length = static_cast<std::uint8_t>((offset + 7) / 8);
  return {};
}

}  // namespace cobridge::pipeline
