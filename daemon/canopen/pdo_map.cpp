#include "canopen/pdo_map.hpp"

#include <algorithm>
#include <string>

#include "base/number_text.hpp"

namespace cobridge::canopen {

namespace {

class PdoMapCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "cobridge.pdo_map"; }
  std::string message(int ev) const override {
    switch (static_cast<PdoMapErrc>(ev)) {
      case PdoMapErrc::too_many_entries: return "more mapping entries than the PDO allows";
      case PdoMapErrc::zero_length: return "mapping entry with length 0";
      case PdoMapErrc::entry_too_long: return "mapped object longer than 32 bits";
      case PdoMapErrc::payload_too_long: return "mapped objects exceed the PDO length";
    }
    return "unknown PDO mapping error";
  }
};

uint64_t load_le64(const std::array<uint8_t, 8>& d) noexcept {
  uint64_t w = 0;
  for (std::size_t i = 0; i < 8; ++i) w |= uint64_t{d[i]} << (8 * i);
  return w;
}

uint64_t mask_bits(uint8_t bits) noexcept {
  return bits >= 64 ? ~uint64_t{0} : (uint64_t{1} << bits) - 1;
}

PdoValueKind dummy_kind(uint16_t index) noexcept {
  // CiA 301 data type indices 0x0002..0x0004 are INTEGER8/16/32.
  return (index >= 0x0002 && index <= 0x0004) ? PdoValueKind::signed_integer
                                               : PdoValueKind::unsigned_integer;
}

}  // namespace

const std::error_category& pdo_map_category() noexcept {
  static const PdoMapCategory category;
  return category;
}

std::error_code make_error_code(PdoMapErrc e) noexcept {
  return {static_cast<int>(e), pdo_map_category()};
}

uint32_t sdo_abort_code(PdoMapErrc e) noexcept {
  switch (e) {
    case PdoMapErrc::zero_length:
    case PdoMapErrc::entry_too_long: return 0x06040041;  // object cannot be mapped
    case PdoMapErrc::too_many_entries:
    case PdoMapErrc::payload_too_long: return 0x06040042;  // would exceed PDO length
  }
  return 0x06040043;  // general parameter incompatibility
}

struct PdoLayoutBuilder {
  static PdoLayoutResult build(std::span<const uint32_t> entries, const PdoTypeLookup& lookup,
                               const PdoLimits& limits) {
    PdoLayoutResult r;
    const std::size_t max_entries = std::min(limits.max_entries, PdoLayout::kMaxFields);
    if (entries.size() > max_entries) {
      r.error = PdoMapErrc::too_many_entries;
      r.message = std::to_string(entries.size()) + " entries, at most " +
                  std::to_string(max_entries);
      return r;
    }
    unsigned offset = 0;
    for (std::size_t i = 0; i < entries.size(); ++i) {
      const PdoMapEntry e = PdoMapEntry::from_raw(entries[i]);
      const std::string where = "entry " + std::to_string(i + 1) + " (" + hex(entries[i], 8) + ")";
      if (e.bits == 0) {
        r.error = PdoMapErrc::zero_length;
        r.message = where + ": length 0";
        return r;
      }
      if (e.bits > 32) {
        r.error = PdoMapErrc::entry_too_long;
        r.message = where + ": " + std::to_string(e.bits) + " bits";
        return r;
      }
      if (offset + e.bits > limits.max_bits || offset + e.bits > 64) {
        r.error = PdoMapErrc::payload_too_long;
        r.message = where + ": ends at bit " + std::to_string(offset + e.bits) + ", limit " +
                    std::to_string(std::min<unsigned>(limits.max_bits, 64));
        return r;
      }
      PdoField& f = r.layout.fields_[i];
      f.index = e.index;
      f.sub = e.sub;
      f.bit_offset = static_cast<uint8_t>(offset);
      f.bit_length = e.bits;
      f.dummy = e.is_dummy();
      if (f.dummy)
        f.kind = dummy_kind(e.index);
      else if (lookup)
        f.kind = lookup(e.index, e.sub);
      offset += e.bits;
    }
    r.layout.count_ = static_cast<uint8_t>(entries.size());
    r.layout.total_bits_ = static_cast<uint8_t>(offset);
    return r;
  }
};

PdoLayoutResult build_pdo_layout(std::span<const uint32_t> entries, const PdoTypeLookup& lookup,
                                 const PdoLimits& limits) {
  return PdoLayoutBuilder::build(entries, lookup, limits);
}

int64_t PdoLayout::value(std::span<const uint8_t, 8> data, std::size_t i) const noexcept {
  const PdoField& f = fields_[i];
  std::array<uint8_t, 8> bytes{};
  for (std::size_t k = 0; k < 8; ++k) bytes[k] = data[k];
  const uint64_t raw = (load_le64(bytes) >> f.bit_offset) & mask_bits(f.bit_length);
  if (f.kind == PdoValueKind::signed_integer && f.bit_length < 64) {
    const uint64_t sign = uint64_t{1} << (f.bit_length - 1U);
    // Two's complement sign extension without implementation-defined casts.
    return static_cast<int64_t>(raw ^ sign) - static_cast<int64_t>(sign);
  }
  return static_cast<int64_t>(raw);
}

PdoDecodeStatus PdoLayout::decode(const can::Frame& frame, std::span<int64_t> out) const noexcept {
  if (frame.is_rtr()) return PdoDecodeStatus::remote_request;
  if (frame.len < frame_length()) return PdoDecodeStatus::too_short;
  if (out.size() < count_) return PdoDecodeStatus::too_few_outputs;
  const std::span<const uint8_t, 8> data(frame.data);
  for (std::size_t i = 0; i < count_; ++i) out[i] = value(data, i);
  return frame.len > frame_length() ? PdoDecodeStatus::ok_longer_frame : PdoDecodeStatus::ok;
}

bool PdoLayout::encode(std::span<const int64_t> values, can::Frame& frame) const noexcept {
  if (values.size() < count_) return false;
  uint64_t word = 0;
  for (std::size_t i = 0; i < count_; ++i) {
    const PdoField& f = fields_[i];
    const uint64_t bits = static_cast<uint64_t>(values[i]) & mask_bits(f.bit_length);
    word |= bits << f.bit_offset;
  }
  frame.len = frame_length();
  for (std::size_t k = 0; k < 8; ++k)
    frame.data[k] = k < frame.len ? static_cast<uint8_t>(word >> (8 * k)) : uint8_t{0};
  return true;
}

}  // namespace cobridge::canopen
