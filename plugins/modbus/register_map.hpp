// RegisterMap: the layout of the Modbus TCP output's register space, the one
// definition shared by the plugin (which renders registers from it) and by
// `cobridge modbus-map` (which exports it as CSV for SCADA import). Holding
// registers (function 0x03) and input registers (0x04) read the same map.
//
//   0 .. 15                  gateway block
//   16 + 8*b                 bus block b (b = 0 .. kMaxBuses-1)
//   144 + 4*b                controller block b: bus b's CAN error counters
//   kDeviceBase + n*kStride  device slot n (n = the daemon's device_index)
//
// 32-bit values occupy two registers; their word order is a configuration
// choice (big = high word first), the bytes inside a register are always
// big-endian (Modbus Application Protocol V1.1b3 §4.2).
//
// Thread contract: constant data and pure functions, any thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace cobridge::modbus {

// Bumped whenever an address, type or scale changes (gateway register 0).
// 2: the command registers of the device slot (+28..+31).
// 3: the CAN controller's state (bus block +3) and the controller blocks.
inline constexpr std::uint16_t kMapVersion = 3;

inline constexpr std::uint16_t kGatewayBase = 0;
inline constexpr std::uint16_t kGatewayBlockSize = 16;
inline constexpr std::uint16_t kBusBase = 16;
inline constexpr std::uint16_t kBusStride = 8;
inline constexpr std::uint16_t kMaxBuses = 16;
// The bus block had one free register (its state went there); the error
// counters and restarts got a block of their own, after the bus blocks.
inline constexpr std::uint16_t kControllerBase = 144;
inline constexpr std::uint16_t kControllerStride = 4;
inline constexpr std::uint16_t kDeviceBase = 256;
inline constexpr std::uint16_t kDeviceStride = 32;
// 256 + 2016 * 32 = 64 768: the slots stay inside the 16-bit address space.
inline constexpr std::uint16_t kMaxDeviceSlots = 2016;

static_assert(kBusBase + kBusStride * kMaxBuses <= kControllerBase);
static_assert(kControllerBase + kControllerStride * kMaxBuses <= kDeviceBase);

enum class RegType : std::uint8_t { kU16, kI16, kU32, kI32 };
enum class Access : std::uint8_t { kRead, kReadWrite };

// Where a register's value comes from; the register image renders by it.
enum class Field : std::uint8_t {
  // gateway block
  kLayoutVersion,
  kVersionMajor,
  kVersionMinor,
  kVersionPatch,
  kUptime,
  kBusCount,
  kDeviceCount,
  kDevicesOnline,
  kDeviceSlots,
  kSlotBase,
  kSlotStride,
  kWordOrder,
  kWritesEnabled,
  kOfflineException,
  // bus block
  kBusState,
  kBusDevices,
  kBusOnline,
  kBusFrames,
  kBusDrops,
  kBusControllerState,
  // controller block
  kControllerTxErrors,
  kControllerRxErrors,
  kControllerRestarts,
  // device slot
  kPosition,
  kSpeed,
  kCamState,
  kWorkAreaState,
  kAlarms,
  kWarnings,
  kNmtState,
  kOnline,
  kStale,
  kDataAge,
  kSequence,
  kEmcyCode,
  kEmcyRegister,
  kTemperature,
  kVoltage,
  kNodeId,
  kBusIndex,
  kSerial,
  kVendorId,
  kProductCode,
  kPresent,
  kValidMask,
  kCommandValue,
  kCommand,
  kCommandStatus,
};

// Bus block register kBusState.
enum class BusState : std::uint16_t { kUnknown = 0, kOk = 1, kDegraded = 2, kDown = 3 };
// Controller block: an error counter the driver does not report.
inline constexpr std::uint16_t kCounterUnknown = 65535;

// One value of the map. `offset` is relative to the block's base.
struct RegisterDef {
  std::uint16_t offset;
  RegType type;
  Field field;
  const char* name;
  const char* unit;  // "" if none
  double scale;      // engineering value = raw * scale
  Access access;
  const char* description;
};

[[nodiscard]] constexpr std::uint16_t word_count(RegType t) noexcept {
  return (t == RegType::kU32 || t == RegType::kI32) ? 2 : 1;
}
[[nodiscard]] const char* type_name(RegType t) noexcept;
[[nodiscard]] const char* access_name(Access a) noexcept;

// The four block layouts, sorted by offset, non-overlapping.
[[nodiscard]] std::span<const RegisterDef> gateway_registers() noexcept;
[[nodiscard]] std::span<const RegisterDef> bus_registers() noexcept;
[[nodiscard]] std::span<const RegisterDef> controller_registers() noexcept;
[[nodiscard]] std::span<const RegisterDef> device_registers() noexcept;

[[nodiscard]] constexpr std::uint16_t bus_base(std::uint16_t bus) noexcept {
  return static_cast<std::uint16_t>(kBusBase + bus * kBusStride);
}
[[nodiscard]] constexpr std::uint16_t controller_base(std::uint16_t bus) noexcept {
  return static_cast<std::uint16_t>(kControllerBase + bus * kControllerStride);
}
[[nodiscard]] constexpr std::uint16_t device_base(std::uint16_t slot) noexcept {
  return static_cast<std::uint16_t>(kDeviceBase + slot * kDeviceStride);
}
// Number of addressable registers for a map with `slots` device slots; a
// request reaching at or past it gets exception 0x02.
[[nodiscard]] constexpr std::uint32_t map_size(std::uint16_t slots) noexcept {
  return static_cast<std::uint32_t>(kDeviceBase) + static_cast<std::uint32_t>(slots) * kDeviceStride;
}

// One row of the exported map: an absolute address and its definition.
struct MapRow {
  std::uint16_t address;
  std::string name;  // e.g. "device[3].position"
  const RegisterDef* def;
};

// Every value of a map with `buses` bus blocks and `slots` device slots, in
// address order (for the CSV export and the documentation test).
[[nodiscard]] std::vector<MapRow> map_rows(std::uint16_t buses, std::uint16_t slots);

// The map as CSV (RFC 4180), header "address,name,type,unit,scale,access,description".
[[nodiscard]] std::string map_csv(std::uint16_t buses, std::uint16_t slots);

}  // namespace cobridge::modbus
