// The metric catalogue of a cobridge device as a Sparkplug device: the
// Sparkplug datatypes (spec 6.4.16), the process metrics each encoder sample
// carries (name, datatype, unit, source object), the identity properties of
// its DBIRTH, and the alias of every metric. One table, read by the session
// (births and data) and by docs/mqtt.md's metric table (checked by a test).
//
// Aliases are unique across the whole edge node, as spec 6.4.4 requires
// (tck-id-payloads-alias-uniqueness): node metrics use 1..255, device d's
// metrics (d + 1) * 256 + metric id.
//
// Thread contract: pure functions and constant tables; any thread. extract()
// runs on the plugin's publisher thread and neither allocates nor throws.
#pragma once

#include <cobridge/plugin.h>

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace cobridge::mqtt {

// Spec 6.4.16: the values of Metric.datatype, as on the wire.
enum class DataType : std::uint32_t {
  kInt8 = 1,
  kInt16 = 2,
  kInt32 = 3,
  kInt64 = 4,
  kUInt8 = 5,
  kUInt16 = 6,
  kUInt32 = 7,
  kUInt64 = 8,
  kFloat = 9,
  kDouble = 10,
  kBoolean = 11,
  kString = 12,
  kDateTime = 13,
  kText = 14,
};

// The device metrics, numbered for their aliases; values are frozen (a
// Sparkplug host keeps aliases across rebirths only if we do).
enum class DeviceMetric : std::uint8_t {
  kPosition = 1,
  kPositionEng = 2,
  kSpeed = 3,
  kCamState = 4,
  kWorkAreaState = 5,
  kAlarms = 6,
  kWarnings = 7,
  kTemperature = 8,
  kVoltage = 9,
  kNmtState = 10,
  kStale = 11,
  kEmcyCode = 12,
  kEmcyRegister = 13,
  // Commands (spec 6.4.x DCMD: a host writes a metric its DBIRTH declared);
  // DBIRTH declares them, DCMD writes 16..19, DDATA reports 19..21.
  kCmdPreset = 16,
  kCmdNmtReset = 17,
  kCmdStore = 18,
  kCmdClient = 19,
  kCmdResult = 20,
  kCmdResultCode = 21,
  // Identity, DBIRTH only (never in DDATA).
  kVendorId = 32,
  kProductCode = 33,
  kRevision = 34,
  kSerial = 35,
  kModel = 36,
  kFamily = 37,
  kNodeId = 38,
  kBus = 39,
};

// Node metric aliases (NBIRTH). bdSeq has none: NDEATH names it (spec 6.4.19).
inline constexpr std::uint64_t kRebirthAlias = 1;
inline constexpr const char* kRebirthName = "Node Control/Rebirth";
inline constexpr const char* kBdSeqName = "bdSeq";

struct MetricDef {
  DeviceMetric id;
  const char* name;    // Sparkplug metric name
  DataType type;
  const char* unit;    // engineering unit property (engUnit), "" = none; "*" = the device's position unit
  const char* source;  // where the value comes from, for docs/mqtt.md
};

// A process value: integers and booleans in `i`, Float/Double in `d`.
struct Scalar {
  std::int64_t i = 0;
  double d = 0.0;
};

struct Reading {
  DeviceMetric id;
  Scalar value;
};

// The process metrics (DBIRTH and DDATA), in alias order.
[[nodiscard]] std::span<const MetricDef> process_metrics() noexcept;
// The command metrics (DBIRTH, DCMD and the DDATA of a command's outcome), in alias order.
[[nodiscard]] std::span<const MetricDef> command_metrics() noexcept;
// The identity metrics (DBIRTH only), in alias order.
[[nodiscard]] std::span<const MetricDef> identity_metrics() noexcept;
// The definition of one metric; nullptr for an unknown id.
[[nodiscard]] const MetricDef* find_metric(DeviceMetric id) noexcept;
// Position of a process metric in process_metrics(), for per-metric state.
[[nodiscard]] std::size_t process_index(DeviceMetric id) noexcept;

// Which process metrics each device publishes ([outputs.mqtt.metrics]): per
// device name, or "*" for every device not named, a mask with bit
// process_index(id) set for each metric its DBIRTH declares and its DDATA
// and history carry. No entry for a device and no "*": every metric.
// Commands and identity are always declared.
struct MetricSets {
  static constexpr std::uint32_t kAll = 0xFFFFFFFFu;
  std::vector<std::pair<std::string, std::uint32_t>> sets;

  [[nodiscard]] std::uint32_t for_device(std::string_view name) const noexcept;
};

// The alias of a device metric (see the file comment).
[[nodiscard]] constexpr std::uint64_t device_alias(std::uint16_t device_index, DeviceMetric id) noexcept {
  return (static_cast<std::uint64_t>(device_index) + 1u) * 256u + static_cast<std::uint64_t>(id);
}

// The process values a sample carries (by its `valid` bits and kind).
// Returns how many readings were written to `out` (at most out.size()).
[[nodiscard]] std::size_t extract(const cobridge_sample& sample, std::span<Reading> out) noexcept;

}  // namespace cobridge::mqtt
