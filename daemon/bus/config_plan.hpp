// ConfigPlan: the SDO configuration of one device, derived from its
// [[device]] settings, its EDS and its family profile, as an ordered list of
// steps that the PlanRunner executes:
//
//   NMT enter pre-operational
//   per configured TPDO: the manuals' remapping procedure (J§1.7.2, E§8.2),
//     transmission type, inhibit time, event timer (ifm: also 0x6200)
//   heartbeat 0x1017 (rotary: fall back to guarding) or guarding 0x100C/0x100D
//   0x6000 (direction, scaling bit, rotary filter) read-modify-write
//   scaling 0x6001/0x6002, preset, CAMs, work area, filters
//   store ('save' to the family's 0x1010 sub-indices, pre-operational only)
//   NMT start
//
// Every write carries the object's size from the EDS DataType, a mask (the
// bits it owns; the rest are kept as read), whether to compare with the
// current value first and whether to read it back. Settings left out of the
// configuration produce no step. Everything that cannot be applied (a CAM the
// family lacks, a signal it cannot map, an object missing from the EDS, a
// value out of the object's range) is reported as a PlanError naming the
// device, the setting and the reason with its manual section, and no plan is
// made.
//
// The fingerprint is a hash of the settings as applied (objects and values,
// sorted, plus the mappings and the store policy), independent of step order
// and time, so the gateway can tell that a device already carries them.
//
// Thread: built on the bus manager's control thread, off the hot path
// (allocates). A plan is an immutable value afterwards.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "base/error.hpp"
#include "canopen/nmt.hpp"
#include "config/config.hpp"
#include "device/eds.hpp"
#include "device/family_profile.hpp"
#include "bus/device_command.hpp"

namespace cobridge::bus {

// Which 0x1010 group a written value belongs to (bits, may be combined).
enum class StoreGroup : std::uint8_t { communication = 0x01, application = 0x02, node_id = 0x04 };
[[nodiscard]] constexpr std::uint8_t bit(StoreGroup g) noexcept { return static_cast<std::uint8_t>(g); }

struct SdoWrite {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::uint8_t size = 4;           // bytes on the wire, 1..4, from the EDS DataType
  std::uint32_t value = 0;         // bit pattern (two's complement for signed types)
  std::uint32_t mask = 0xFFFFFFFFu; // bits this write owns; others keep the value read
  bool read_first = true;          // read and compare before writing (false: write-only, signatures)
  bool verify = true;              // read back after writing and compare the owned bits
  std::uint8_t groups = 0;         // StoreGroup bits

  // Only the bits of `size` bytes.
  [[nodiscard]] constexpr std::uint32_t size_mask() const noexcept {
    return size >= 4 ? 0xFFFFFFFFu : ((1u << (8u * size)) - 1u);
  }
  [[nodiscard]] constexpr std::uint32_t owned() const noexcept { return mask & size_mask(); }
  // The value to write given the value read.
  [[nodiscard]] constexpr std::uint32_t merged(std::uint32_t current) const noexcept {
    return ((current & ~owned()) | (value & owned())) & size_mask();
  }
};

struct StoreTarget {
  std::uint8_t sub = 1;     // 0x1010 sub-index
  std::uint8_t groups = 0;  // StoreGroup bits it saves
};

enum class StepKind : std::uint8_t { nmt, write, tpdo_mapping, store };

struct PlanStep {
  StepKind kind = StepKind::write;
  std::string label;  // the setting, as messages name it: "tpdo1 transmission", "cam 5 low"

  canopen::NmtCommand nmt = canopen::NmtCommand::enter_preop;  // kind nmt

  SdoWrite write;  // kind write
  // kind write: applied instead when the device aborts `write` (not on a
  // timeout): the rotary series' guarding fallback for 0x1017 (J§1.2.2).
  std::vector<SdoWrite> fallback;
  std::string fallback_label;

  // kind tpdo_mapping: the TPDO (1-based), its parameter objects and the
  // mapping wanted (0xIIIISSLL entries; empty = PDO left disabled).
  std::uint8_t tpdo = 0;
  std::uint16_t comm_index = 0;  // 0x1800 + tpdo - 1
  std::uint16_t map_index = 0;   // 0x1A00 + tpdo - 1
  std::vector<std::uint32_t> mapping;

  std::vector<StoreTarget> store;  // kind store
};

struct ConfigPlan {
  std::string device;
  std::uint8_t node_id = 0;
  const families::Family* family = nullptr;
  config::StorePolicy store_policy = config::StorePolicy::on_change;
  std::vector<PlanStep> steps;
  // How the device is supervised after the plan (before any fallback).
  bool heartbeat = false;
  std::uint16_t heartbeat_ms = 0;
  std::string fingerprint;  // 16 lower-case hex digits
  std::uint64_t fingerprint_value = 0;
};

struct PlanError {
  std::string device;
  std::string setting;
  std::string reason;
  bool out_of_range = false;  // the value is outside the object's type or EDS limits
  // "device 'lift': cam 5: the multiturn series has 4 CAMs (E§3.4)"
  [[nodiscard]] std::string to_string() const;
  // The project's one error shape: kInvalidArgument, where = "device 'lift': cam 5",
  // message = the reason.
  [[nodiscard]] Error to_error() const;
};

struct ConfigPlanResult {
  std::optional<ConfigPlan> plan;
  std::vector<PlanError> errors;
  [[nodiscard]] bool ok() const noexcept { return plan.has_value(); }
};

[[nodiscard]] ConfigPlanResult make_config_plan(const config::Device& device,
                                                const device::DeviceDescription& description,
                                                const device::FamilyProfile& profile, std::uint8_t node_id);

// Commissioning by SDO: pre-operational, the family's node-ID object (ifm:
// value = node-ID - 1, F§7.4) and optionally its bit-rate object, 'save' to
// the node-ID sub-index (J§1.6.1 /4, RSX/RFX /1, E§7.1 /4, F /1) regardless of
// policy. No NMT start: the new ID applies after reset communication or power
// up (J§1.6.1, E§7.1, F§6.3.2), which the caller sends.
[[nodiscard]] ConfigPlanResult make_node_id_plan(const std::string& device_name,
                                                 const device::DeviceDescription& description,
                                                 const device::FamilyProfile& profile, std::uint8_t current_node_id,
                                                 std::uint8_t new_node_id,
                                                 std::optional<std::uint16_t> bitrate_kbit = std::nullopt);

// A command a plugin submitted (device_command.hpp), as a plan for the
// PlanRunner, run with start_node = true:
//   preset    the family's preset object(s) (J§1.3.2 0x6010 per channel,
//             E§4.2 / F§7.5 0x6003) = value, always written (the position
//             moved since it was last set), read back; no store, no NMT.
//   nmt_reset NMT reset node; the boot-up that follows restarts the device's
//             configuration like any other boot-up.
//   store     pre-operational where the family requires it (J§1.10, E§11,
//             F§6.1.1), 'save' to the family's communication and application
//             sub-indices of 0x1010, NMT start.
// A value outside the object's type or EDS limits, or an object the EDS
// lacks, is a PlanError naming the device, the command and the reason.
[[nodiscard]] ConfigPlanResult make_command_plan(const std::string& device_name,
                                                 const device::DeviceDescription& description,
                                                 const device::FamilyProfile& profile, std::uint8_t node_id,
                                                 CommandKind kind, std::int64_t value);

// FNV-1a, 64 bit (the public-domain constants), and its 16-digit hex text.
[[nodiscard]] std::uint64_t fnv1a64(const void* data, std::size_t size,
                                    std::uint64_t seed = 0xcbf29ce484222325ull) noexcept;
[[nodiscard]] std::string fingerprint_text(std::uint64_t value);

}  // namespace cobridge::bus
