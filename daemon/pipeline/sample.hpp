// Sample: the C++ face of cobridge_sample, the fixed-size event value that
// travels from a bus RX thread through the SPSC ring to the dispatcher and on
// to the plugins (see include/cobridge/plugin.h for the field meanings).
//
// The layout is part of the plugin ABI, so it is pinned here with
// static_asserts: any change that moves a field fails the build instead of
// silently breaking plugins built against an older header.
//
// Thread contract: plain value helpers, usable from any thread; all of them
// are noexcept and allocation-free (they run per frame).
#pragma once

#include <cobridge/plugin.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <type_traits>

namespace cobridge::pipeline {

using Sample = cobridge_sample;

static_assert(std::is_trivially_copyable_v<Sample>, "samples are copied with plain stores through the ring");
static_assert(std::is_standard_layout_v<Sample>, "samples cross a C ABI");
static_assert(sizeof(Sample) == 128, "cobridge_sample size is frozen by the plugin ABI");
static_assert(alignof(Sample) == 8);
// Offsets are ABI: a plugin built against ABI 1 reads the fields here.
static_assert(offsetof(Sample, rx_timestamp_ns) == 0);
static_assert(offsetof(Sample, publish_timestamp_ns) == 8);
static_assert(offsetof(Sample, sequence) == 16);
static_assert(offsetof(Sample, device_index) == 20);
static_assert(offsetof(Sample, bus_index) == 22);
static_assert(offsetof(Sample, node_id) == 23);
static_assert(offsetof(Sample, kind) == 24);
static_assert(offsetof(Sample, sync_counter) == 25);
static_assert(offsetof(Sample, valid) == 26);
static_assert(offsetof(Sample, speed) == 28);
static_assert(offsetof(Sample, position) == 32);
static_assert(offsetof(Sample, position_eng) == 40);
static_assert(offsetof(Sample, alarms) == 48);
static_assert(offsetof(Sample, warnings) == 50);
static_assert(offsetof(Sample, temperature_dC) == 52);
static_assert(offsetof(Sample, voltage_dV) == 54);
static_assert(offsetof(Sample, cam_state) == 56);
static_assert(offsetof(Sample, work_area_state) == 57);
static_assert(offsetof(Sample, nmt_state) == 58);
static_assert(offsetof(Sample, online) == 59);
static_assert(offsetof(Sample, stale) == 60);
static_assert(offsetof(Sample, emcy_register) == 61);
static_assert(offsetof(Sample, emcy_code) == 62);
static_assert(offsetof(Sample, emcy_data) == 64);
static_assert(offsetof(Sample, raw_len) == 69);
static_assert(offsetof(Sample, cob_id) == 70);
static_assert(offsetof(Sample, raw) == 72);
// ABI 2 took the first 10 bytes of the ABI 1 reserved tail.
static_assert(offsetof(Sample, command_tag) == 80);
static_assert(offsetof(Sample, command_abort_code) == 84);
static_assert(offsetof(Sample, command_kind) == 88);
static_assert(offsetof(Sample, command_status) == 89);
static_assert(offsetof(Sample, rx_monotonic_ns) == 96);
static_assert(offsetof(Sample, kind_sequence) == 104);  // ABI 2, from the reserved tail
static_assert(offsetof(Sample, reserved) == 108);
// Host API: ABI 1's fields keep their offsets; submit_command follows.
static_assert(offsetof(cobridge_host_api, gateway_id) == 24);
static_assert(offsetof(cobridge_host_api, submit_command) == 32);
static_assert(sizeof(cobridge_command) == 24);

// The mandatory part of the ops table is frozen too; optional ops follow it.
static_assert(offsetof(cobridge_plugin_ops, start) == 16);
static_assert(offsetof(cobridge_plugin_ops, on_samples) == 40);
static_assert(COBRIDGE_PLUGIN_OPS_MIN_SIZE == 48);
static_assert(offsetof(cobridge_plugin_ops, on_device) == 48);
static_assert(offsetof(cobridge_plugin_ops, on_role) == 64);
static_assert(offsetof(cobridge_plugin_ops, on_bus) == 72);  // ABI 5
// ABI 5's bus info: no implicit padding, 64-bit fields aligned.
static_assert(offsetof(cobridge_bus_info, tx_errors) == 10);
static_assert(offsetof(cobridge_bus_info, restarts) == 24);
static_assert(offsetof(cobridge_bus_info, bus_name) == 48);
static_assert(sizeof(cobridge_bus_info) == 56);

enum class SampleKind : std::uint8_t {
  kTpdo = COBRIDGE_SAMPLE_TPDO,
  kEmcy = COBRIDGE_SAMPLE_EMCY,
  kHeartbeat = COBRIDGE_SAMPLE_HEARTBEAT,
  kNmtState = COBRIDGE_SAMPLE_NMT_STATE,
  kStatus = COBRIDGE_SAMPLE_STATUS,
  kCommand = COBRIDGE_SAMPLE_COMMAND,
};

// Bits of Sample::valid.
enum class Field : std::uint16_t {
  kPosition = COBRIDGE_VALID_POSITION,
  kPositionEng = COBRIDGE_VALID_POSITION_ENG,
  kSpeed = COBRIDGE_VALID_SPEED,
  kCamState = COBRIDGE_VALID_CAM_STATE,
  kWorkAreaState = COBRIDGE_VALID_WORK_AREA_STATE,
  kAlarms = COBRIDGE_VALID_ALARMS,
  kWarnings = COBRIDGE_VALID_WARNINGS,
  kTemperature = COBRIDGE_VALID_TEMPERATURE,
  kVoltage = COBRIDGE_VALID_VOLTAGE,
  kNmtState = COBRIDGE_VALID_NMT_STATE,
  kStatus = COBRIDGE_VALID_STATUS,
  kEmcy = COBRIDGE_VALID_EMCY,
  kRaw = COBRIDGE_VALID_RAW,
  kCommand = COBRIDGE_VALID_COMMAND,
};

// A zeroed sample with the header filled in (zero matters: reserved bytes
// and fields not flagged valid must read as 0 in every plugin).
[[nodiscard]] inline Sample make_sample(SampleKind kind, std::uint16_t device_index, std::uint8_t bus_index,
                                        std::uint8_t node_id, std::uint64_t rx_timestamp_ns) noexcept {
  Sample s{};
  s.kind = static_cast<std::uint8_t>(kind);
  s.device_index = device_index;
  s.bus_index = bus_index;
  s.node_id = node_id;
  s.rx_timestamp_ns = rx_timestamp_ns;
  return s;
}

[[nodiscard]] inline bool has(const Sample& s, Field f) noexcept {
  return (s.valid & static_cast<std::uint16_t>(f)) != 0;
}
inline void mark(Sample& s, Field f) noexcept {
  s.valid = static_cast<std::uint16_t>(s.valid | static_cast<std::uint16_t>(f));
}

inline void set_position(Sample& s, std::int64_t counts) noexcept {
  s.position = counts;
  mark(s, Field::kPosition);
}
inline void set_position_eng(Sample& s, double value) noexcept {
  s.position_eng = value;
  mark(s, Field::kPositionEng);
}
inline void set_speed(Sample& s, std::int32_t speed) noexcept {
  s.speed = speed;
  mark(s, Field::kSpeed);
}
inline void set_status(Sample& s, bool online, bool stale) noexcept {
  s.online = online ? 1 : 0;
  s.stale = stale ? 1 : 0;
  mark(s, Field::kStatus);
}
inline void set_nmt_state(Sample& s, std::uint8_t state) noexcept {
  s.nmt_state = state;
  mark(s, Field::kNmtState);
}
// `frame` is the 8-byte EMCY payload (CiA 301 §7.2.7.3.1): code LE, register,
// 5 manufacturer bytes.
inline void set_emcy(Sample& s, std::span<const std::uint8_t, 8> frame) noexcept {
  s.emcy_code = static_cast<std::uint16_t>(frame[0] | (frame[1] << 8));
  s.emcy_register = frame[2];
  std::memcpy(s.emcy_data, frame.data() + 3, sizeof s.emcy_data);
  mark(s, Field::kEmcy);
}
// Keeps at most 8 bytes (a classic CAN payload).
inline void set_raw(Sample& s, std::uint16_t cob_id, std::span<const std::uint8_t> payload) noexcept {
  const std::size_t n = payload.size() < sizeof s.raw ? payload.size() : sizeof s.raw;
  s.cob_id = cob_id;
  s.raw_len = static_cast<std::uint8_t>(n);
  if (n != 0) std::memcpy(s.raw, payload.data(), n);
  mark(s, Field::kRaw);
}

}  // namespace cobridge::pipeline
