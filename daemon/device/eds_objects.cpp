// The EDS parser: the object lists and object sections (CiA 306 §4.5,
// §4.6) and the cross-checks of the parsed description.
#include "device/eds_parser.hpp"

#include <algorithm>
#include <cmath>
#include <cerrno>
#include <cstdlib>
#include <limits>

namespace cobridge::device::eds_detail {

void Parser::read_list(std::string_view name, ObjectList list) {
  const Section* s = section(name);
  if (s == nullptr) return;
  const Line* count_line = s->get("supportedobjects");
  if (count_line == nullptr) {
    error(s->line, 0, EdsErrc::kMissingKey, "[" + s->name + "] SupportedObjects is missing");
    return;
  }
  const auto count = number(*s, *count_line, 0xFFFF);
  if (!count) return;
  for (const Line& l : s->lines) {
    if (&l == count_line) continue;
    const auto n = parse_unsigned(l.key);
    if (!n || *n == 0 || *n > *count) {
      error(l.line, 1, EdsErrc::kInconsistent,
            "[" + s->name + "] unexpected key '" + std::string(l.key) + "' (allowed: SupportedObjects and 1.." +
                std::to_string(*count) + ")");
      continue;
    }
    const auto idx = number(*s, l, 0xFFFF);
    if (!idx) continue;
    const auto index = static_cast<std::uint16_t>(*idx);
    const bool manufacturer_range = index >= 0x2000 && index <= 0x5FFF;
    if ((list == ObjectList::kManufacturer) != manufacturer_range) {
      error(l.line, l.value_column, EdsErrc::kInconsistent,
            where(*s, l) + (list == ObjectList::kManufacturer
                                ? " is outside the manufacturer area (allowed: 0x2000..0x5FFF)"
                                : " is in the manufacturer area 0x2000..0x5FFF (belongs in [ManufacturerObjects])"));
      continue;
    }
    const auto [it, inserted] = listed_.emplace(index, ListedObject{list, l.line, s->name, std::string(l.key)});
    if (!inserted) {
      error(l.line, l.value_column, EdsErrc::kInconsistent,
            where(*s, l) + ": " + hex(index, 4) + " is already listed at line " + std::to_string(it->second.line));
    }
  }
  for (std::uint64_t i = 1; i <= *count; ++i) {
    if (s->get(std::to_string(i)) == nullptr) {
      error(s->line, 0, EdsErrc::kInconsistent,
            "[" + s->name + "] SupportedObjects=" + std::to_string(*count) + " but entry " + std::to_string(i) +
                " is missing");
      break;
    }
  }
}

Parser::Address Parser::classify(const std::string& n) {
  Address a;
  if (n.size() < 4) return a;
  for (std::size_t i = 0; i < 4; ++i) {
    if (hex_digit(n[i]) < 0) return a;
  }
  const auto idx = parse_unsigned("0x" + n.substr(0, 4));
  a.index = static_cast<std::uint16_t>(idx.value_or(0));
  if (n.size() == 4) {
    a.is_object = true;
    return a;
  }
  if (n.compare(4, 3, "sub") != 0) return a;  // e.g. [1018Value], [1018Name]: not used
  a.is_sub = true;
  const std::string rest = n.substr(7);
  const auto sub = rest.empty() || rest.size() > 2 ? std::nullopt : parse_unsigned("0x" + rest);
  if (!sub) {
    a.malformed = true;
  } else {
    a.sub = static_cast<std::uint8_t>(*sub);
  }
  return a;
}

std::optional<ObjectType> Parser::object_type(const Section& s) {
  const Line* l = s.get("objecttype");
  if (l == nullptr) return ObjectType::kVar;  // CiA 306: VAR when absent
  const auto v = parse_unsigned(l->value);
  if (v) {
    switch (*v) {
      case 0x0: case 0x2: case 0x5: case 0x6: case 0x7: case 0x8: case 0x9:
        return static_cast<ObjectType>(*v);
      default:
        break;
    }
  }
  error(l->line, v ? 0 : l->value_column, EdsErrc::kBadObjectType,
        where(s, *l) + " is not a CiA 306 object type (allowed: 0x0 NULL, 0x2 DOMAIN, 0x5 DEFTYPE, "
                       "0x6 DEFSTRUCT, 0x7 VAR, 0x8 ARRAY, 0x9 RECORD)");
  return std::nullopt;
}

// Reads the entry keys of a VAR object or a sub-object section.
void Parser::read_entry(const Section& s, std::uint16_t index, std::uint8_t sub, ObjectType type) {
  ObjectDesc d;
  d.index = index;
  d.sub = sub;
  d.line = s.line;
  bool ok = read_name(s, d);
  ok = read_data_type(s, type, d) && ok;
  ok = read_access(s, d) && ok;
  ok = read_flags(s, d) && ok;
  if (!ok) return;  // values cannot be checked without a valid type
  if (!read_values(s, d)) return;
  if (seen_.count({index, sub}) != 0) {
    error(s.line, 0, EdsErrc::kDuplicateSection,
          "[" + s.name + "] describes " + hex(index, 4) + " sub " + std::to_string(sub) +
              " again (first at line " + std::to_string(seen_[{index, sub}]) + ")");
    return;
  }
  seen_[{index, sub}] = s.line;
  desc_.entries.push_back(std::move(d));
}

bool Parser::read_name(const Section& s, ObjectDesc& d) {
  if (const Line* l = s.get("parametername")) {
    d.name = std::string(l->value);
    return true;
  }
  error(s.line, 0, EdsErrc::kMissingKey, "[" + s.name + "] ParameterName is missing (required by CiA 306)");
  return false;
}

bool Parser::read_data_type(const Section& s, ObjectType type, ObjectDesc& d) {
  const Line* dt = s.get("datatype");
  if (dt == nullptr && type == ObjectType::kDomain) {
    d.data_type = DataType::kDomain;
    return true;
  }
  if (dt == nullptr) {
    error(s.line, 0, EdsErrc::kMissingKey, "[" + s.name + "] DataType is missing (required for a VAR)");
    return false;
  }
  const auto code = parse_unsigned(dt->value);
  const std::optional<DataType> data_type = code ? canopen::data_type_from_code(*code) : std::nullopt;
  if (!code) {
    error(dt->line, dt->value_column, EdsErrc::kBadNumber,
          where(s, *dt) + " is not a number (allowed: decimal, 0x hexadecimal, 0 octal)");
    return false;
  }
  if (!data_type) {
    error(dt->line, 0, EdsErrc::kBadDataType,
          where(s, *dt) + " is not a CiA 301 data type (allowed: 0x0001..0x001B" +
              (*code == 0x0E || *code == 0x17 ? ", except the reserved 0x000E and 0x0017)" : ")"));
    return false;
  }
  d.data_type = *data_type;
  return true;
}

bool Parser::read_access(const Section& s, ObjectDesc& d) {
  const Line* l = s.get("accesstype");
  if (l == nullptr) {
    error(s.line, 0, EdsErrc::kMissingKey, "[" + s.name + "] AccessType is missing (required for a VAR)");
    return false;
  }
  const std::string a = lower(l->value);
  const auto it = std::find_if(kAccess.begin(), kAccess.end(), [&](const auto& p) { return p.first == a; });
  if (it == kAccess.end()) {
    error(l->line, 0, EdsErrc::kBadAccessType,
          where(s, *l) + " is not a CiA 306 access type (allowed: ro, wo, rw, rwr, rww, const)");
    return false;
  }
  d.access = it->second;
  return true;
}

// PDOMapping, and CompactSubObj (refused: one section per sub-index).
bool Parser::read_flags(const Section& s, ObjectDesc& d) {
  bool ok = true;
  if (const Line* l = s.get("pdomapping")) {
    const auto v = parse_unsigned(l->value);
    if (!v || *v > 1) {
      error(l->line, l->value_column, EdsErrc::kBadNumber, where(s, *l) + " is not a flag (allowed: 0, 1)");
      ok = false;
    } else {
      d.pdo_mapping = *v == 1;
    }
  }
  if (const Line* l = s.get("compactsubobj")) {
    if (parse_unsigned(l->value).value_or(1) != 0) {
      error(l->line, 0, EdsErrc::kUnsupported,
            where(s, *l) + ": CompactSubObj is not supported (write one [IIIIsubS] section per sub-index)");
      ok = false;
    }
  }
  return ok;
}

// LowLimit, HighLimit and DefaultValue in the entry's type, and consistent
// with each other; false when any of them is in error.
bool Parser::read_values(const Section& s, ObjectDesc& d) {
  const std::size_t before = errors_.size();
  const Line* lo = s.get("lowlimit");
  const Line* hi = s.get("highlimit");
  const Line* dv = s.get("defaultvalue");
  if (lo != nullptr) d.low_limit = value(s, *lo, d.data_type, false);
  if (hi != nullptr) d.high_limit = value(s, *hi, d.data_type, false);
  if (dv != nullptr) d.default_value = value(s, *dv, d.data_type, true);
  if (errors_.size() != before) return false;

  const bool sign = is_signed_integer(d.data_type);
  auto as_signed = [&](std::uint64_t raw) {
    ObjectDesc tmp;
    tmp.data_type = d.data_type;
    tmp.default_value.kind = EdsValue::Kind::kInteger;
    tmp.default_value.integer = raw;
    return tmp.default_signed_for_node(0).value_or(0);
  };
  auto less = [&](std::uint64_t a, std::uint64_t b) { return sign ? as_signed(a) < as_signed(b) : a < b; };
  auto show = [&](std::uint64_t raw) {
    return sign ? std::to_string(as_signed(raw)) : std::to_string(raw);
  };
  using K = EdsValue::Kind;
  if (d.low_limit.kind == K::kInteger && d.high_limit.kind == K::kInteger &&
      less(d.high_limit.integer, d.low_limit.integer)) {
    error(hi->line, 0, EdsErrc::kInconsistent,
          "[" + s.name + "] HighLimit=" + std::string(hi->value) + " is below LowLimit=" + std::string(lo->value));
  }
  if (d.default_value.kind == K::kInteger && !d.default_value.plus_node_id) {
    const std::uint64_t v = d.default_value.integer;
    const bool below = d.low_limit.kind == K::kInteger && less(v, d.low_limit.integer);
    const bool above = d.high_limit.kind == K::kInteger && less(d.high_limit.integer, v);
    if (below || above) {
      std::string range = (d.low_limit.kind == K::kInteger ? show(d.low_limit.integer) : std::string{}) + ".." +
                          (d.high_limit.kind == K::kInteger ? show(d.high_limit.integer) : std::string{});
      error(dv->line, dv->value_column, EdsErrc::kOutOfRange,
            where(s, *dv) + " is outside the limits (allowed: " + range + ")");
    }
  }
  return true;
}

namespace {
bool is_aggregate(ObjectType t) {
  return t == ObjectType::kArray || t == ObjectType::kRecord || t == ObjectType::kDefStruct;
}
}  // namespace

void Parser::read_objects() {
  // Objects first, so that sub sections can find their parent wherever
  // they appear in the file.
  ObjectSections objects;
  for (const Section& s : sections_) {
    const Address a = classify(s.name_lower);
    if (!a.is_object) continue;
    if (auto e = read_object(s, a.index)) objects.emplace(a.index, std::pair{&s, *e});
  }
  std::map<std::uint16_t, std::size_t> sub_counts;
  for (const Section& s : sections_) {
    const Address a = classify(s.name_lower);
    if (!a.is_sub) continue;
    if (read_sub_object(s, a, objects)) ++sub_counts[a.index];
  }
  for (auto& [index, pair] : objects) {
    const auto& [s, e] = pair;
    if (is_aggregate(e.type)) check_sub_count(*s, e, sub_counts[index]);
    desc_.objects.push_back(e);
  }
}

std::optional<ObjectEntry> Parser::read_object(const Section& s, std::uint16_t index) {
  ObjectEntry e;
  e.index = index;
  e.line = s.line;
  if (const Line* l = s.get("parametername")) e.name = std::string(l->value);
  const auto type = object_type(s);
  if (!type) return std::nullopt;
  e.type = *type;
  const auto listed = listed_.find(index);
  if (listed == listed_.end()) {
    error(s.line, 0, EdsErrc::kUnlistedObject,
          "[" + s.name + "] is not named in [MandatoryObjects], [OptionalObjects] or [ManufacturerObjects]");
  } else {
    e.list = listed->second.list;
  }
  if (is_aggregate(e.type)) {
    if (s.get("parametername") == nullptr) {
      error(s.line, 0, EdsErrc::kMissingKey, "[" + s.name + "] ParameterName is missing (required by CiA 306)");
    }
    if (const Line* l = s.get("subnumber")) {
      if (const auto n = number(s, *l, 0xFF)) e.sub_number = static_cast<std::uint8_t>(*n);
    } else {
      error(s.line, 0, EdsErrc::kMissingKey, "[" + s.name + "] SubNumber is missing (required for ARRAY/RECORD)");
    }
    if (const Line* l = s.get("compactsubobj"); l != nullptr && parse_unsigned(l->value).value_or(1) != 0) {
      error(l->line, 0, EdsErrc::kUnsupported,
            where(s, *l) + ": CompactSubObj is not supported (write one [IIIIsubS] section per sub-index)");
    }
  } else if (e.type != ObjectType::kNull) {
    read_entry(s, index, 0, e.type);
  }
  return e;
}

bool Parser::read_sub_object(const Section& s, const Address& a, const ObjectSections& objects) {
  if (a.malformed) {
    error(s.line, 0, EdsErrc::kSyntax,
          "[" + s.name + "] is not a sub-object section name (allowed: [IIIIsubS], S = 0..FF hexadecimal)");
    return false;
  }
  const auto parent = objects.find(a.index);
  const Section* parent_section = section(lower(hex(a.index, 4).substr(2)));
  if (parent == objects.end()) {
    if (parent_section == nullptr) {
      error(s.line, 0, EdsErrc::kSubWithoutParent,
            "[" + s.name + "] has no parent object section [" + hex(a.index, 4).substr(2) + "]");
    }
    return false;  // the parent exists but was rejected: already reported
  }
  if (!is_aggregate(parent->second.second.type)) {
    error(s.line, 0, EdsErrc::kSubWithoutParent,
          "[" + s.name + "] belongs to [" + parent->second.first->name +
              "], which is not an ARRAY or RECORD (ObjectType 0x8 or 0x9)");
    return false;
  }
  const auto type = object_type(s);
  if (!type) return false;
  if (*type != ObjectType::kVar) {
    error(s.get("objecttype")->line, 0, EdsErrc::kBadObjectType,
          "[" + s.name + "] ObjectType of a sub-object must be 0x7 (VAR)");
    return false;
  }
  read_entry(s, a.index, a.sub, ObjectType::kVar);
  return true;
}

void Parser::check_sub_count(const Section& s, const ObjectEntry& e, std::size_t count) {
  if (s.get("subnumber") != nullptr && count != e.sub_number) {
    error(s.get("subnumber")->line, 0, EdsErrc::kInconsistent,
          "[" + s.name + "] SubNumber=" + std::to_string(e.sub_number) + " but " + std::to_string(count) +
              " sub-object sections [" + s.name + "subS] exist");
  }
  if (seen_.count({e.index, 0}) == 0 && count != 0) {
    error(s.line, 0, EdsErrc::kMissingSection,
          "[" + s.name + "] has no sub-index 0 section [" + s.name + "sub0] (CiA 301: highest sub-index)");
  }
}

void Parser::check_listed_sections() {
  for (const auto& [index, listed] : listed_) {
    if (section(lower(hex(index, 4).substr(2))) == nullptr) {
      error(listed.line, 0, EdsErrc::kMissingSection,
            "[" + listed.list_name + "] " + listed.entry + "=" + hex(index, 4) + " names section [" +
                hex(index, 4).substr(2) + "], which is missing");
    }
  }
}

void Parser::check_identity() {
  const auto& d = desc_.device_info;
  const Section* di = section("deviceinfo");
  if (di == nullptr) return;
  const std::pair<std::uint8_t, std::uint32_t> checks[] = {{1, d.vendor_number}, {2, d.product_number}};
  for (const auto& [sub, expected] : checks) {
    const ObjectDesc* o = desc_.find(0x1018, sub);
    if (o == nullptr || o->default_value.kind != EdsValue::Kind::kInteger || o->default_value.plus_node_id) continue;
    if (o->default_value.integer != expected) {
      error(o->line, 0, EdsErrc::kInconsistent,
            "[1018sub" + std::to_string(sub) + "] DefaultValue=" + o->default_value.text + " differs from [" +
                di->name + "] " + (sub == 1 ? "VendorNumber=" : "ProductNumber=") + hex(expected, 8));
    }
  }
}

void Parser::check_selection() {
  const auto& sel = desc_.selection;
  if (sel.probe_index && desc_.find(*sel.probe_index, sel.probe_sub) == nullptr) {
    error(probe_line_, 0, EdsErrc::kInconsistent,
          "[Cobridge] VariantProbe names " + hex(*sel.probe_index, 4) + " sub " + std::to_string(sel.probe_sub) +
              ", which the file does not describe");
  }
}

}  // namespace cobridge::device::eds_detail
