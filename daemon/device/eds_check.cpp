// EDS check: see eds_check.hpp.
#include "device/eds_check.hpp"

#include <algorithm>
#include <string>

#include "device/eds_parser.hpp"
#include "families/family.hpp"

namespace cobridge::device {

namespace {

// "6020" for 0x6020: the index as EDS section names write it.
std::string hex4(std::uint32_t v) { return eds_detail::hex(v, 4).substr(2); }

std::string section_name(std::uint16_t index, std::optional<std::uint8_t> sub = std::nullopt) {
  std::string s = "[" + hex4(index);
  if (sub) s += "sub" + std::to_string(*sub);
  return s + "]";
}

class Findings {
 public:
  explicit Findings(const DeviceDescription& d) : d_(d) {}
  void add(EdsErrc code, const std::string& section, std::string message) {
    out_.emplace_back(Errc::kInvalidArgument, std::move(message), d_.source + " " + section, make_error_code(code));
  }
  [[nodiscard]] std::vector<Error> take() { return std::move(out_); }

 private:
  const DeviceDescription& d_;
  std::vector<Error> out_;
};

std::string_view list_name(ObjectList list) noexcept {
  switch (list) {
    case ObjectList::kMandatory: return "MandatoryObjects";
    case ObjectList::kOptional: return "OptionalObjects";
    case ObjectList::kManufacturer: return "ManufacturerObjects";
  }
  return "?";
}

// CiA 306 §4.5: which list an index belongs to.
ObjectList expected_list(std::uint16_t index) noexcept {
  if (index == 0x1000 || index == 0x1001 || index == 0x1018) return ObjectList::kMandatory;
  if (index >= 0x2000 && index <= 0x5FFF) return ObjectList::kManufacturer;
  return ObjectList::kOptional;
}

void check_object_lists(const DeviceDescription& d, Findings& f) {
  for (const ObjectEntry& o : d.objects) {
    const ObjectList want = expected_list(o.index);
    if (o.list != want) {
      f.add(EdsErrc::kInconsistent, section_name(o.index),
            "listed in [" + std::string(list_name(o.list)) + "]; CiA 306 §4.5 puts 0x" + hex4(o.index) + " in [" +
                std::string(list_name(want)) + "]");
    }
  }
  for (const std::uint16_t index : {std::uint16_t{0x1000}, std::uint16_t{0x1001}, std::uint16_t{0x1018}}) {
    if (d.object(index) == nullptr)
      f.add(EdsErrc::kMissingSection, section_name(index), "mandatory object (CiA 301 §7.5, CiA 306 §4.5) is missing");
  }
}

std::vector<const ObjectDesc*> entries_of(const DeviceDescription& d, std::uint16_t index) {
  std::vector<const ObjectDesc*> out;
  for (const ObjectDesc& e : d.entries) {
    if (e.index == index) out.push_back(&e);
  }
  return out;
}

// Objects whose sub-index 0 counts the entries in use rather than naming the
// highest sub-index: the error history (CiA 301 §7.5.2.3) and the PDO
// mappings (§7.5.2.36).
bool counts_entries(std::uint16_t index) noexcept {
  return index == 0x1003 || (index >= 0x1600 && index <= 0x17FF) || (index >= 0x1A00 && index <= 0x1BFF);
}

void check_sub0(const DeviceDescription& d, const ObjectEntry& o, std::uint8_t highest, Findings& f) {
  const ObjectDesc* sub0 = d.find(o.index, 0);
  if (sub0 == nullptr) {
    f.add(EdsErrc::kMissingSection, section_name(o.index, 0), "an ARRAY/RECORD needs sub-index 0 (CiA 301 §7.4.3)");
    return;
  }
  if (sub0->data_type != DataType::kUnsigned8)
    f.add(EdsErrc::kBadDataType, section_name(o.index, 0), "sub-index 0 must be UNSIGNED8 (CiA 301 §7.4.3)");
  if (sub0->access != AccessType::kRo && sub0->access != AccessType::kConst && sub0->access != AccessType::kRw)
    f.add(EdsErrc::kBadAccessType, section_name(o.index, 0), "sub-index 0 must be readable (ro, const or rw)");
  const auto n = sub0->default_for_node(0);
  if (!n || sub0->default_value.plus_node_id) return;
  if (counts_entries(o.index)) {
    if (*n > highest) {
      f.add(EdsErrc::kInconsistent, section_name(o.index, 0),
            "DefaultValue=" + std::to_string(*n) + " counts more entries than the " + std::to_string(highest) +
                " defined");
    }
  } else if (*n != highest) {
    f.add(EdsErrc::kInconsistent, section_name(o.index, 0),
          "DefaultValue=" + std::to_string(*n) + " but the highest sub-index defined is " + std::to_string(highest) +
              " (CiA 301 §7.4.3: sub-index 0 is the highest sub-index supported)");
  }
}

void check_object_shapes(const DeviceDescription& d, Findings& f) {
  for (const ObjectEntry& o : d.objects) {
    const auto entries = entries_of(d, o.index);
    if (o.type != ObjectType::kArray && o.type != ObjectType::kRecord) continue;
    std::uint8_t highest = 0;
    for (const ObjectDesc* e : entries) highest = std::max(highest, e->sub);
    check_sub0(d, o, highest, f);
    if (o.sub_number != entries.size()) {
      f.add(EdsErrc::kInconsistent, section_name(o.index),
            "SubNumber=" + std::to_string(o.sub_number) + " but " + std::to_string(entries.size()) +
                " sub-objects are defined (CiA 306 §4.6.3)");
    }
    if (o.type != ObjectType::kArray) continue;
    const ObjectDesc* first = d.find(o.index, 1);
    for (const ObjectDesc* e : entries) {
      if (first != nullptr && e->sub > 0 && e->data_type != first->data_type) {
        f.add(EdsErrc::kBadDataType, section_name(o.index, e->sub),
              "an ARRAY's entries share one data type (CiA 301 §7.4.3); sub-index 1 is " +
                  std::string(to_string(first->data_type)) + ", this one " + std::string(to_string(e->data_type)));
      }
    }
  }
}

bool readable(AccessType a) noexcept {
  return a == AccessType::kRo || a == AccessType::kRw || a == AccessType::kRwr || a == AccessType::kConst;
}
bool writable(AccessType a) noexcept {
  return a == AccessType::kWo || a == AccessType::kRw || a == AccessType::kRww;
}

// One default mapping entry of a TPDO (tx) or RPDO mapping object.
std::uint32_t check_mapping_entry(const DeviceDescription& d, const ObjectDesc& slot, bool tx, Findings& f) {
  const auto value = slot.default_for_node(0);
  if (!value || *value == 0) return 0;
  const auto index = static_cast<std::uint16_t>(*value >> 16);
  const auto sub = static_cast<std::uint8_t>((*value >> 8) & 0xFFu);
  const auto bits = static_cast<std::uint32_t>(*value & 0xFFu);
  const std::string where = section_name(slot.index, slot.sub);
  const std::string names = "maps 0x" + hex4(index) + "/" + std::to_string(sub);
  if (!tx && index >= 0x0001 && index <= 0x0007) return bits;  // CiA 301 §7.4.8.1 dummy mapping
  const ObjectDesc* o = d.find(index, sub);
  if (o == nullptr) {
    f.add(EdsErrc::kMissingSection, where, names + ", which the file does not define (CiA 301 §7.4.8.1)");
    return bits;
  }
  if (!o->pdo_mapping) f.add(EdsErrc::kInconsistent, where, names + ", which has PDOMapping=0");
  if (bits != o->bits()) {
    f.add(EdsErrc::kInconsistent, where,
          names + " with " + std::to_string(bits) + " bits, but its type " + std::string(to_string(o->data_type)) +
              " has " + std::to_string(o->bits()));
  }
  if (tx ? !readable(o->access) : !writable(o->access)) {
    f.add(EdsErrc::kBadAccessType, where,
          names + ", whose access " + std::string(to_string(o->access)) + " a " + (tx ? "TPDO cannot read" : "RPDO cannot write"));
  }
  return bits;
}

void check_mapping_object(const DeviceDescription& d, std::uint16_t index, bool tx, Findings& f) {
  for (const ObjectDesc* e : entries_of(d, index)) {
    if (e->sub > 0 && e->data_type != DataType::kUnsigned32)
      f.add(EdsErrc::kBadDataType, section_name(index, e->sub), "a PDO mapping entry is UNSIGNED32 (CiA 301 §7.5.2.36)");
  }
  const ObjectDesc* sub0 = d.find(index, 0);
  const auto n = sub0 ? sub0->default_for_node(0) : std::nullopt;
  if (!n) return;
  if (*n > 64) f.add(EdsErrc::kOutOfRange, section_name(index, 0), "a PDO maps at most 64 objects (CiA 301 §7.4.8)");
  std::uint32_t total = 0;
  for (std::uint32_t s = 1; s <= std::min<std::uint64_t>(*n, 64); ++s) {
    const ObjectDesc* slot = d.find(index, static_cast<std::uint8_t>(s));
    if (slot == nullptr) {
      f.add(EdsErrc::kMissingSection, section_name(index, static_cast<std::uint8_t>(s)),
            "sub-index 0 says " + std::to_string(*n) + " objects are mapped; this entry is missing");
      continue;
    }
    total += check_mapping_entry(d, *slot, tx, f);
  }
  if (total > 64)
    f.add(EdsErrc::kOutOfRange, section_name(index), std::to_string(total) + " bits mapped; a PDO carries 64 (CiA 301 §7.4.8)");
}

// NrOfTXPDO / NrOfRXPDO against the communication and mapping objects present.
void check_pdo_set(const DeviceDescription& d, std::uint16_t comm_base, std::uint16_t map_base, std::uint16_t declared,
                   std::string_view key, Findings& f) {
  std::uint16_t count = 0;
  for (std::uint16_t n = 0; n < 512; ++n) {
    const bool comm = d.object(static_cast<std::uint16_t>(comm_base + n)) != nullptr;
    const bool map = d.object(static_cast<std::uint16_t>(map_base + n)) != nullptr;
    if (comm) ++count;
    if (comm != map) {
      f.add(EdsErrc::kInconsistent, section_name(static_cast<std::uint16_t>(comm ? comm_base + n : map_base + n)),
            "a PDO needs both its communication (0x" + hex4(comm_base + n) + ") and its mapping (0x" +
                hex4(map_base + n) + ") object");
    }
  }
  if (count != declared) {
    f.add(EdsErrc::kInconsistent, "[DeviceInfo]",
          std::string(key) + "=" + std::to_string(declared) + " but the file defines " + std::to_string(count) +
              " such PDOs (CiA 306 §4.4)");
  }
}

void check_pdos(const DeviceDescription& d, Findings& f) {
  for (const ObjectEntry& o : d.objects) {
    if (o.index >= 0x1600 && o.index <= 0x17FF) check_mapping_object(d, o.index, false, f);
    if (o.index >= 0x1A00 && o.index <= 0x1BFF) check_mapping_object(d, o.index, true, f);
  }
  check_pdo_set(d, 0x1400, 0x1600, d.device_info.nr_of_rx_pdo, "NrOfRXPDO", f);
  check_pdo_set(d, 0x1800, 0x1A00, d.device_info.nr_of_tx_pdo, "NrOfTXPDO", f);
}

void check_family_objects(const DeviceDescription& d, Findings& f) {
  const families::Family* family = families::find_family(d.selection.family);
  if (family == nullptr) return;
  for (const std::uint16_t index : family->manual_objects) {
    if (d.object(index) == nullptr) {
      f.add(EdsErrc::kMissingSection, section_name(index),
            "manual " + std::string(family->manual) + " (" + std::string(family->series) +
                ") names this object; the file does not define it");
    }
  }
}

}  // namespace

std::vector<Error> check_eds(const DeviceDescription& description) {
  Findings f(description);
  check_object_lists(description, f);
  check_object_shapes(description, f);
  check_pdos(description, f);
  check_family_objects(description, f);
  return f.take();
}

}  // namespace cobridge::device
