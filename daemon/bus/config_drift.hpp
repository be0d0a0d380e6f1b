// Configuration drift: a client (the CLI through the control socket, a
// CiA 309-3 client, a plugin's command) wrote an object the device's
// configuration plan sets, to a value other than the configured one. The
// gateway then knows the device no longer carries its configuration even
// though nothing failed (measured: a 309-3 write of 0x1017 from 100 to
// 9029 ms went unnoticed until the heartbeat was missed).
//
// Pure functions over a ConfigPlan: which object a write touches, what the
// plan wants there, and whether the written value differs in the bits the
// plan owns (SdoWrite::owned(): a read-modify-write of 0x6000 owns only the
// bits of its settings; a write changing only other bits is no drift).
//
// Objects the plan sets: every write step (not its fallback: the rotary
// series' guarding objects are only written when 0x1017 was refused), and
// for each TPDO mapping step the number of entries (0x1A0n:00), each entry
// (0x1A0n:01..) and the valid bit (bit 31) of the COB-ID (0x180n:01).
//
// Thread: the bus's control thread calls these; plain values, no state.
#pragma once

#include "bus/config_plan.hpp"
#include "bus/device_status.hpp"

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace cobridge::bus {

// What the plan wants in one object.
struct ConfiguredObject {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::uint8_t size = 4;             // bytes
  std::uint32_t value = 0;           // configured bits (only `owned` matter)
  std::uint32_t owned = 0xFFFFFFFFu;  // the bits the plan sets
  std::string name;                  // the plan's label: "heartbeat", "tpdo1 mapping entry 2"
};

// The object at index:sub the plan sets, if any.
[[nodiscard]] std::optional<ConfiguredObject> configured_object(const ConfigPlan& plan, std::uint16_t index,
                                                                std::uint8_t sub);

// The outcome of a client's write.
struct DriftCheck {
  bool configured = false;  // the plan sets the object
  bool differs = false;     // ... and the written value differs in the owned bits
  DriftRecord record;       // filled when configured
};

// `bytes`: the value written, little-endian as on the wire (CiA 301 §7.1);
// at most the first 4 bytes are read (the plan sets no longer objects).
[[nodiscard]] DriftCheck check_write(const ConfigPlan& plan, std::uint16_t index, std::uint8_t sub,
                                     std::span<const std::uint8_t> bytes, std::string writer, WallTime at);

// "0x1017:00 (heartbeat) set to 9029 (0x233D) by <writer> (configured 100 (0x64))"
[[nodiscard]] std::string drift_text(const DriftRecord& r);
// "0x1017:00", "9029 (0x233D)"
[[nodiscard]] std::string object_key(std::uint16_t index, std::uint8_t sub);
[[nodiscard]] std::string number_text(std::uint32_t value);

// What a checked write does to a device's open records.
enum class DriftChange : std::uint8_t {
  none,      // not a configured object, or the value was and stays the configured one
  opened,    // a new record (or a record's value changed)
  restored,  // the configured value was written back: the record is gone
};
// Updates `open` (one record per object, most recent last) with `check`.
DriftChange apply_check(std::vector<DriftRecord>& open, const DriftCheck& check);
// The open record of index:sub, if any.
[[nodiscard]] DriftRecord* open_record(std::vector<DriftRecord>& open, std::uint16_t index, std::uint8_t sub);
// `check` is the same value by the same writer as an open record: nothing
// new (a writer that keeps writing its value gets one record, one line).
[[nodiscard]] bool repeats_open_record(const std::vector<DriftRecord>& open, const DriftCheck& check);

}  // namespace cobridge::bus
