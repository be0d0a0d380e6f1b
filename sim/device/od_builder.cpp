#include "device/od_builder.hpp"

#include <algorithm>
#include <fmt/format.h>
#include <optional>

namespace cobridge::sim {

namespace {

constexpr std::uint32_t kMinStringCapacity = 32;

// Limits and defaults arrive as bit patterns truncated to the type's width;
// the dictionary wants numbers, so signed types are sign-extended here.
canopen::Number to_number(device::DataType type, std::uint64_t bits) noexcept {
  if (device::is_signed_integer(type)) {
    const std::uint32_t width = device::bit_size(type);
    if (width > 0 && width < 64) {
      const std::uint64_t sign = std::uint64_t{1} << (width - 1U);
      const std::uint64_t mask = (std::uint64_t{1} << width) - 1U;
      const std::uint64_t v = bits & mask;
      return canopen::Number(static_cast<std::int64_t>(v ^ sign) - static_cast<std::int64_t>(sign));
    }
    return canopen::Number(static_cast<std::int64_t>(bits));
  }
  return canopen::Number(bits);
}

std::optional<canopen::Number> limit(const device::ObjectDesc& e, const device::EdsValue& v) {
  if (v.kind != device::EdsValue::Kind::kInteger) return std::nullopt;
  return to_number(e.data_type, v.integer);
}

}  // namespace

canopen::DataType to_od_type(device::DataType type) noexcept {
  // The two enums share the CiA 301 values; the EDS parser rejects the
  // reserved ones, and the unsupported time types fail at insert.
  return static_cast<canopen::DataType>(static_cast<std::uint16_t>(type));
}

canopen::Access to_od_access(device::AccessType access) noexcept {
  switch (access) {
    case device::AccessType::kRo: return canopen::Access::kRo;
    case device::AccessType::kWo: return canopen::Access::kWo;
    case device::AccessType::kConst: return canopen::Access::kConst;
    case device::AccessType::kRw:
    case device::AccessType::kRwr:
    case device::AccessType::kRww: return canopen::Access::kRw;
  }
  return canopen::Access::kRw;
}

bool is_string_type(device::DataType type) noexcept {
  return type == device::DataType::kVisibleString || type == device::DataType::kOctetString ||
         type == device::DataType::kDomain || type == device::DataType::kUnicodeString;
}

std::uint64_t eds_default_raw(const device::ObjectDesc& entry, std::uint8_t node_id) noexcept {
  if (is_string_type(entry.data_type)) return 0;
  return entry.default_for_node(node_id).value_or(0);
}

Error build_object_dictionary(const device::DeviceDescription& description, std::uint8_t node_id,
                              canopen::ObjectDictionary& od,
                                        const EntryAdjust& adjust) {
  // An unconfigured device (FFh) still has an object dictionary; its
  // $NODEID entries are meaningless until LSS gives it an ID, so resolve
  // them as if the node were 0.
  const std::uint8_t resolve_id = node_id == 0xFF ? 0 : node_id;
  for (const device::ObjectDesc& e : description.entries) {
    canopen::EntryDef def;
    def.index = e.index;
    def.sub = e.sub;
    def.type = to_od_type(e.data_type);
    def.access = to_od_access(e.access);
    def.pdo_mappable = e.pdo_mapping;
    def.name = e.name;
    if (is_string_type(e.data_type)) {
      def.text = e.default_value.kind == device::EdsValue::Kind::kNone ? std::string_view{}
                                                                         : std::string_view{e.default_value.text};
      def.capacity = std::max<std::uint32_t>(kMinStringCapacity, static_cast<std::uint32_t>(def.text.size()));
    } else {
      def.value = to_number(e.data_type, eds_default_raw(e, resolve_id));
      def.low = limit(e, e.low_limit);
      def.high = limit(e, e.high_limit);
      // A default the file leaves open (0) may lie below a lower limit;
      // start at the limit instead of refusing the whole file.
      if (def.low && e.default_value.kind == device::EdsValue::Kind::kNone) def.value = *def.low;
    }
    if (adjust) adjust(def);
    if (const std::error_code ec = od.insert(def)) {
      return Error(Errc::kInvalidArgument,
                   fmt::format("entry 0x{:04X}sub{:X} ({}): {}", e.index, e.sub, e.name, ec.message()),
                   description.source, ec);
    }
  }
  return {};
}

}  // namespace cobridge::sim
