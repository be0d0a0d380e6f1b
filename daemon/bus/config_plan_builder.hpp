// The ConfigPlan builder (config_plan.hpp is the interface): one Builder per
// plan, its member functions in one file per concept:
//   config_plan.cpp              the three entry points, the node-ID and command
//                                plans, and the write primitives (require,
//                                encode, add_value, add_bits)
//   config_plan_communication.cpp TPDOs (J§1.7.2, E§8.2, F§7.3), heartbeat /
//                                guarding, store (0x1010) and the fingerprint
//   config_plan_application.cpp  0x6000, scaling, preset, CAMs, work area,
//                                filters (CiA 406 and the families' objects)
// Thread contract: a Builder is a local of make_*_plan; the bus manager's
// control thread, off the hot path.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "base/number_text.hpp"
#include "bus/config_plan.hpp"

namespace cobridge::bus::plan_detail {

using device::DataType;
using device::ObjectRef;

using cobridge::hex;
[[nodiscard]] inline std::string object_text(ObjectRef o) { return cobridge::object_text(o.index, o.sub); }
[[nodiscard]] std::string signal_name(config::Signal s);

// The bounds of an integer type.
struct Range {
  std::int64_t low;
  std::int64_t high;
};
[[nodiscard]] std::optional<Range> type_range(DataType t);
[[nodiscard]] std::int64_t limit_value(const device::ObjectDesc& d, const device::EdsValue& v);

class Builder {
 public:
  Builder(const config::Device& dev, const device::DeviceDescription& eds, const device::FamilyProfile& profile,
          std::uint8_t node_id)
      : dev_(dev), eds_(eds), profile_(profile) {
    plan_.device = dev.name;
    plan_.node_id = node_id;
    plan_.family = profile.family;
    plan_.store_policy = dev.store;
  }
  // make_node_id_plan
  ConfigPlanResult build_node_id(std::uint8_t new_node_id, std::optional<std::uint16_t> bitrate_kbit);
  // make_command_plan
  ConfigPlanResult build_command(CommandKind kind, std::int64_t value);
  ConfigPlanResult build();
 private:
  ConfigPlanResult finish();
  void error(std::string setting, std::string reason);
  void add_nmt(std::string label, canopen::NmtCommand cmd);
  // The EDS entry of `o`, or an error naming the setting.
  const device::ObjectDesc* require(const std::string& setting, ObjectRef o, bool writable = true);
  static SdoWrite skeleton(const device::ObjectDesc& d, std::uint8_t groups);
  // `value` checked against the object's type and EDS limits; the bit pattern.
  std::optional<std::uint32_t> encode(const std::string& setting, const device::ObjectDesc& d, std::int64_t value);
  // A plain write of `value` to `o`.
  void add_value(std::string label, ObjectRef o, std::int64_t value, std::uint8_t groups);
  // A read-modify-write of the bits in `mask`.
  void add_bits(std::string label, ObjectRef o, std::uint32_t value, std::uint32_t mask, std::uint8_t groups);
  void tpdo(std::uint8_t n, const std::optional<config::TpdoSettings>& settings);
  void mapping(std::uint8_t n, const std::string& name, std::uint16_t comm, std::uint16_t map, const std::vector<config::MappingEntry>& entries);
  // Whether the TPDO's parameter and mapping objects exist and hold `count` entries.
  bool mapping_objects_fit(std::uint8_t n, const std::string& label, std::uint16_t comm, std::uint16_t map,
                           std::size_t count);
  // One entry as the device takes it (0xIIIISSLL); none when it cannot be mapped.
  std::optional<std::uint32_t> mapping_entry(const std::string& what, const config::MappingEntry& e,
                                             bool& speed_mapped);
  void supervision();
  [[nodiscard]] bool scaling_requested() const;
  void operating_parameters();
  void scaling();
  [[nodiscard]] std::string channel_suffix(std::uint8_t ch) const;
  void preset();
  void cams();
  void work_area();
  void filters();
  void store();
  void fingerprint();
  const config::Device& dev_;
  const device::DeviceDescription& eds_;
  const device::FamilyProfile& profile_;
  ConfigPlan plan_;
  std::vector<PlanError> errors_;
};

}  // namespace cobridge::bus::plan_detail
