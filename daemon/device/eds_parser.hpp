// The EDS parser's private parts (daemon/device/eds.hpp is the interface):
// the text helpers, the key=value sections of pass 1, and the Parser, whose
// member functions live in one file per concept:
//   eds_parser.cpp    the run, errors, numbers and values (CiA 306 §4.6.3)
//   eds_sections.cpp  pass 1 (lines into sections) and the header sections
//                     [FileInfo], [DeviceInfo], [Cobridge] (CiA 306 §4.3, §4.4)
//   eds_objects.cpp   the object lists and object sections (CiA 306 §4.5, §4.6)
//                     and the cross-checks
// Thread contract: a Parser is a local of parse_eds; one thread, off the hot path.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "base/number_text.hpp"
#include "device/eds.hpp"

namespace cobridge::device::eds_detail {

inline constexpr std::size_t kMaxErrors = 64;
inline constexpr std::size_t kMaxFileBytes = 4U * 1024U * 1024U;

// CiA 306 §4.6.3 AccessType values as written.
inline constexpr std::array<std::pair<std::string_view, AccessType>, 6> kAccess{{
    {"ro", AccessType::kRo},
    {"wo", AccessType::kWo},
    {"rw", AccessType::kRw},
    {"rwr", AccessType::kRwr},
    {"rww", AccessType::kRww},
    {"const", AccessType::kConst},
}};

// The low `bits` bits set (all 64 for 0 or >= 64).
[[nodiscard]] constexpr std::uint64_t mask_bits(std::uint32_t bits) noexcept {
  if (bits == 0 || bits >= 64) return ~std::uint64_t{0};
  return (std::uint64_t{1} << bits) - 1;
}

[[nodiscard]] std::string lower(std::string_view s);
[[nodiscard]] bool is_space(char c) noexcept;
[[nodiscard]] int hex_digit(char c) noexcept;  // -1 if not a hex digit
[[nodiscard]] std::string_view trim(std::string_view s) noexcept;
using cobridge::hex;  // base/number_text
// An unsigned integer in CiA 306 notation: decimal, 0x hexadecimal or
// leading-0 octal; no sign.
[[nodiscard]] std::optional<std::uint64_t> parse_unsigned(std::string_view s, bool* is_decimal = nullptr) noexcept;

struct Line {
  std::string_view key;  // original case, trimmed
  std::string key_lower;
  std::string_view value;
  std::size_t line = 0;
  std::size_t value_column = 0;
};

struct Section {
  std::string name;  // as written
  std::string name_lower;
  std::size_t line = 0;
  std::vector<Line> lines;

  const Line* get(std::string_view key_lower) const noexcept {
    for (const auto& l : lines) {
      if (l.key_lower == key_lower) return &l;
    }
    return nullptr;
  }
};

class Parser {
 public:
  Parser(std::string_view text, std::string_view file) : text_(text), file_(file) {}
  EdsResult run();
 private:
  // -- errors ---------------------------------------------------------------
  void error(std::size_t line, std::size_t column, EdsErrc code, std::string message);
  // -- pass 1: lines into sections ---------------------------------------------
  void split();
  // Reports a control character; false when the line has one.
  bool check_printable(std::size_t line_no, std::string_view raw);
  // Starts the section of header `t`; a bad or duplicate one gets `discard`.
  Section* open_section(std::size_t line_no, std::size_t indent, std::string_view t, Section& discard);
  // Adds the Key=Value line `t` to `current`.
  void add_key(std::size_t line_no, std::size_t indent, std::string_view t, Section* current, const Section& discard);
  const Section* section(std::string_view name_lower) const;
  // -- value helpers -------------------------------------------------------------
  std::string where(const Section& s, const Line& l) const { return "[" + s.name + "] " + std::string(l.key) + "=" + std::string(l.value); }
  std::optional<std::uint64_t> number(const Section& s, const Line& l, std::uint64_t max);
  bool flag(const Section& s, const Line& l);
  template <typename T>
  void read_number(const Section& s, std::string_view key, T& out) {
    if (const Line* l = s.get(key)) {
      if (const auto v = number(s, *l, std::numeric_limits<T>::max())) out = static_cast<T>(*v);
    }
  }
  void read_flag(const Section& s, std::string_view key, bool& out);
  void read_text(const Section& s, std::string_view key, std::string& out);
  // Parses DefaultValue / LowLimit / HighLimit for `type`.
  EdsValue value(const Section& s, const Line& l, DataType type, bool allow_node_id);
  // An integer value as written: sign, sum of its numbers, $NODEID.
  struct IntegerTerms {
    std::uint64_t sum = 0;
    bool negative = false;
    bool all_decimal = true;
    bool node = false;
  };
  std::optional<IntegerTerms> integer_terms(const Section& s, const Line& l, bool allow_node_id);
  bool integer_fits(const Section& s, const Line& l, DataType type, const IntegerTerms& t);
  // -- pass 2 --------------------------------------------------------------------
  struct ListedObject {
    ObjectList list;
    std::size_t line;
    std::string list_name;
    std::string entry;
  };
  void interpret();
  void read_file_info(const Section& s);
  void read_device_info(const Section& s);
  // "0x6020sub0" -> (index, sub)
  static std::optional<std::pair<std::uint16_t, std::uint8_t>> parse_address(std::string_view text);
  void read_selection(const Section& s);
  void read_list(std::string_view name, ObjectList list);
  // Classifies a section name: object (index), sub-object (index, sub) or other.
  struct Address {
    bool is_object = false;
    bool is_sub = false;
    bool malformed = false;
    std::uint16_t index = 0;
    std::uint8_t sub = 0;
  };
  static Address classify(const std::string& n);
  std::optional<ObjectType> object_type(const Section& s);
  // Reads the entry keys of a VAR object or a sub-object section.
  void read_entry(const Section& s, std::uint16_t index, std::uint8_t sub, ObjectType type);
  bool read_name(const Section& s, ObjectDesc& d);
  bool read_data_type(const Section& s, ObjectType type, ObjectDesc& d);
  bool read_access(const Section& s, ObjectDesc& d);
  bool read_flags(const Section& s, ObjectDesc& d);
  bool read_values(const Section& s, ObjectDesc& d);
  void read_objects();
  using ObjectSections = std::map<std::uint16_t, std::pair<const Section*, ObjectEntry>>;
  // Reads an object section; none when its ObjectType is unusable.
  std::optional<ObjectEntry> read_object(const Section& s, std::uint16_t index);
  // Reads a sub-object section; false when it is not one of a usable parent.
  bool read_sub_object(const Section& s, const Address& a, const ObjectSections& objects);
  // Checks an ARRAY's or RECORD's SubNumber against its `count` sub-objects.
  void check_sub_count(const Section& s, const ObjectEntry& e, std::size_t count);
  void check_listed_sections();
  void check_identity();
  void check_selection();
  std::string_view text_;
  std::string file_;
  std::vector<Section> sections_;
  std::map<std::string, std::size_t> section_index_;
  std::map<std::uint16_t, ListedObject> listed_;
  std::map<std::pair<std::uint16_t, std::uint8_t>, std::size_t> seen_;
  std::size_t probe_line_ = 0;
  DeviceDescription desc_;
  std::vector<EdsError> errors_;
};

}  // namespace cobridge::device::eds_detail
