// EncoderFrontEnd: the sensing side of a simulated encoder, i.e. what the
// device's position objects read at a given time, per channel.
//
// This is the one place where the device turns motion into position, speed,
// CAM and work-area values; the computations themselves are the encoder
// library's (sim/encoder: Motion, PositionPipeline, CamBank, WorkArea).
// The device copies its object-dictionary values in with configure() after
// every relevant write and reads a ChannelSample every 1 ms measuring cycle.
// Thread: the device's thread; measure() is noexcept and allocation-free.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string_view>
#include <system_error>

#include "canopen/clock.hpp"
#include "encoder/cam.hpp"
#include "encoder/motion.hpp"
#include "encoder/position_pipeline.hpp"
#include "encoder/work_area.hpp"

#include "device/sim_device.hpp"

namespace cobridge::sim {

using canopen::TimePoint;

struct CamConfig {
  std::uint8_t count = 0;  // CAMs on this channel (4 Novotechnik, 8 ifm)
  std::uint8_t enable = 0;
  std::uint8_t polarity = 0;
  std::array<std::int64_t, 8> low{};
  std::array<std::int64_t, 8> high{};
  std::array<std::int64_t, 8> hysteresis{};
};

// The object-dictionary values one channel's computation reads.
struct ChannelConfig {
  std::uint16_t operating_parameter = 0;  // 0x6000 (ifm: bit 0 shared with 0x2100)
  std::uint32_t per_rev = 0;              // 0x6001
  std::uint32_t total = 0;                // 0x6002
  std::uint8_t position_filter = 0;       // E 0x2010/1
  std::uint16_t speed_integration_ms = 1; // E 0x6031/2
  bool speed_enabled = true;              // F 0x3010/1
  std::uint8_t speed_mode = 0;            // F 0x3010/2
  bool limit_min_enabled = false;         // F 0x2100 bit 1
  bool limit_max_enabled = false;         // F 0x2100 bit 2
  std::uint32_t limit_min = 0;            // F 0x2104
  std::uint32_t limit_max = 0;            // F 0x2105
  CamConfig cams;
  bool has_work_area = false;
  WorkAreaLimits work_area{};
};

struct ChannelSample {
  std::uint32_t position_bits = 0;  // the position object's wire bits (sentinels, ifm limit bits)
  std::int64_t position = 0;        // output value for CAMs / work area (meaningless on error)
  std::uint32_t raw = 0;            // E 0x600C
  std::int32_t speed = 0;           // 0x6030/1 (already saturated to INTEGER16)
  std::int32_t speed32 = 0;         // F 0x3011
  std::uint8_t cams = 0;            // 0x6300/ch
  std::uint8_t cam_changed = 0;
  std::uint8_t cam_active = 0;      // before polarity (lot-size counter)
  std::uint8_t work_area = 0;       // 0x6400/ch
  bool error_value = false;
  bool speed_saturated = false;     // E§10.1 bit 19, E§10.3 bit 6
  RangeState range = RangeState::in_range;
  double shaft_turns = 0.0;
};

class EncoderFrontEnd {
 public:
  static constexpr int kMaxChannels = 2;

  // `physical` comes from 0x6501/0x6502 of the device's dictionary.
  void set_family(FamilyId family, Resolution physical) noexcept;
  // Motion grammar of encoder/motion.hpp. The shaft keeps its time origin
  // across power cycles (an absolute encoder sees where the shaft went).
  [[nodiscard]] Error set_motion(std::string_view spec, TimePoint now);
  // Turns the shaft by hand (control `move`): the offset adds up and stays
  // across set_motion, since the shaft does not go back when the drive changes.
  void move_by(double turns) noexcept { motion_.set_offset(motion_.offset() + turns); }
  void configure(int channel, const ChannelConfig& config) noexcept;

  // Preset (CiA 406: the current output reads P). check first, then apply.
  [[nodiscard]] std::uint32_t check_preset(int channel, std::int64_t value) const noexcept;
  void preset(int channel, std::int64_t value) noexcept;
  [[nodiscard]] std::int64_t offset(int channel) const noexcept;
  void restore_offset(int channel, std::int64_t offset, std::int64_t preset) noexcept;

  void set_measurement_error(bool on) noexcept;
  // E 0x2100: true if a latched out-of-range error was cleared.
  bool position_error_reset() noexcept;
  // Power cycle / reset node: filters, latches and CAM memory start over.
  void reset() noexcept;

  [[nodiscard]] ChannelSample measure(int channel, TimePoint now) noexcept;
  [[nodiscard]] const PositionSettings* settings(int channel) const noexcept;

 private:
  struct Channel {
    std::optional<PositionPipeline> pipeline;
    CamBank cams{4};
    std::optional<WorkArea> work_area;
  };
  [[nodiscard]] double seconds(TimePoint now) const noexcept;

  FamilyId family_ = FamilyId::novotechnik_rotary;
  Resolution physical_{};
  Motion motion_{};
  bool started_ = false;
  TimePoint origin_{};
  std::array<Channel, kMaxChannels> channels_{};
};

}  // namespace cobridge::sim
