// OD builder: turns a family's EDS description into the simulated device's
// CiA 301 object dictionary.
//
// Types, access, PDO-mappability and limits come from the EDS entries as
// they are; defaults have $NODEID resolved for the node-ID the device boots
// with. Strings get a fixed capacity (their default or 32 bytes, whichever is
// longer) because the dictionary never reallocates after setup.
// Family quirks (aliases, values the EDS leaves open such as serial numbers)
// are applied afterwards by the device through the typed setters.
// Thread: setup only (power on, reset); allocates.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <system_error>

#include "canopen/object_dictionary.hpp"
#include "device/eds.hpp"

namespace cobridge::sim {

[[nodiscard]] canopen::DataType to_od_type(device::DataType type) noexcept;
[[nodiscard]] canopen::Access to_od_access(device::AccessType access) noexcept;
[[nodiscard]] bool is_string_type(device::DataType type) noexcept;

// The EDS default of `entry` for `node_id` as the little-endian bit pattern
// (0 when the file gives none or the type is a string).
[[nodiscard]] std::uint64_t eds_default_raw(const device::ObjectDesc& entry, std::uint8_t node_id) noexcept;

// Lets the family change an entry before it is inserted (an access the
// manual contradicts, a default the EDS leaves open).
using EntryAdjust = std::function<void(canopen::EntryDef&)>;

// Inserts every entry of `description`; a failure has the description's
// source as its where, names the entry and carries the dictionary's code.
[[nodiscard]] Error build_object_dictionary(const device::DeviceDescription& description, std::uint8_t node_id,
                                            canopen::ObjectDictionary& od, const EntryAdjust& adjust = {});

}  // namespace cobridge::sim
