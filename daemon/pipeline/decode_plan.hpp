// DecodePlan: how the hot path turns one device's TPDOs into sample fields.
//
// Built on the control thread from the mapping the device really has
// (0x1A00/0x1A01 as read back after configuration) and the signedness of
// each mapped object (from its EDS), then handed to the hot path. It is a
// small trivially copyable value so the RX thread can keep its own copy and
// decode without touching shared memory per frame.
#pragma once

#include "base/error.hpp"

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <type_traits>

namespace cobridge::pipeline {

// The semantic signals every output speaks, for every device family.
enum class Signal : std::uint8_t {
  none,         // mapped but not a known signal (kept in raw bytes only)
  position,     // 0x6004, 0x6020/ch (rotary, and the multiturn default mapping), 0x600C raw
  speed,        // 0x6030/ch
  cam,          // 0x6300/1
  work_area,    // 0x6400/1
  alarms,       // 0x6503
  warnings,     // 0x6505
  temperature,  // 0x2002 (multiturn, 0.1 degC)
  voltage,      // 0x2003 (multiturn, 0.1 V)
};

// Which mapped object means which signal (CiA 406 objects and the multiturn
// condition-monitoring objects E§4.3). Channel 2 objects are not channel 1.
[[nodiscard]] Signal signal_of(std::uint16_t index, std::uint8_t sub) noexcept;

struct FieldDecode {
  std::uint8_t bit_offset = 0;
  std::uint8_t bit_length = 0;
  bool is_signed = false;
  Signal signal = Signal::none;
};

struct PdoDecode {
  static constexpr std::size_t kMaxFields = 8;  // 8 bytes; the seed devices map at most 5 (J§1.7.2)
  std::uint8_t count = 0;
  std::uint8_t frame_length = 0;  // bytes the frame must carry
  std::array<FieldDecode, kMaxFields> fields{};
};

struct DecodePlan {
  bool active = false;          // false: TPDOs of this node are counted, not decoded
  // device_index belongs to the device at node_id. Without it nothing of the
  // node is published (EMCY, heartbeat, status included): a frame is never
  // attributed to another device's index; it is counted as unknown_node.
  bool indexed = false;
  std::uint16_t device_index = 0;
  std::uint8_t node_id = 0;
  std::array<PdoDecode, 2> tpdo{};  // TPDO1, TPDO2
  // TPDO transmission type 1..240 (sent on SYNC): samples carry the counter
  // of the SYNC that triggered them (CiA 301 §7.2.5.3.3).
  std::array<bool, 2> synchronous{};
  // Values older than this are flagged stale (0 = never): a few event-timer
  // periods, chosen by the control thread.
  std::uint32_t max_age_ms = 0;
  // position_eng = position * eng_scale + eng_offset (e.g. 360/units per rev).
  double eng_scale = 1.0;
  double eng_offset = 0.0;
  // ifm (F§7.4 0x2104/0x2105): bits 30/31 of the position are limit-switch
  // flags when enabled; the position value is bits 29..0.
  std::uint32_t position_mask = 0xFFFFFFFFu;
};
static_assert(std::is_trivially_copyable_v<DecodePlan>);

// One mapping entry (0xIIIISSLL) and whether the object is a signed integer.
struct MappedObject {
  std::uint32_t entry = 0;
  bool is_signed = false;
};

// Builds the TPDO part of a plan (control thread); kUnsupported when the
// mapping cannot be decoded (more than 8 fields, longer than 64 bits, a field
// longer than 32 bits), `out` then decodes nothing.
[[nodiscard]] Error build_pdo_decode(std::span<const MappedObject> mapping, PdoDecode& out);

}  // namespace cobridge::pipeline
