// CiA 306 EDS parser. Two passes: the text is split into sections of
// key=value lines (syntax errors, duplicates), then the sections are
// interpreted (object lists, objects, values) and cross-checked.
#include "device/eds.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <new>
#include <utility>

namespace cobridge::device {

// ---------------------------------------------------------------------------
// Data types and access types

namespace {

constexpr std::array<std::pair<std::string_view, AccessType>, 6> kAccess{{
    {"ro", AccessType::kRo},
    {"wo", AccessType::kWo},
    {"rw", AccessType::kRw},
    {"rwr", AccessType::kRwr},
    {"rww", AccessType::kRww},
    {"const", AccessType::kConst},
}};

}  // namespace

std::string_view to_string(AccessType type) noexcept {
  for (const auto& [name, value] : kAccess) {
    if (value == type) return name;
  }
  return "?";
}

// ---------------------------------------------------------------------------
// Lookups

namespace {
std::uint64_t mask_bits(std::uint32_t bits) noexcept {
  if (bits == 0 || bits >= 64) return ~std::uint64_t{0};
  return (std::uint64_t{1} << bits) - 1;
}
}  // namespace

std::optional<std::uint64_t> ObjectDesc::default_for_node(std::uint8_t node_id) const noexcept {
  if (default_value.kind != EdsValue::Kind::kInteger) return std::nullopt;
  std::uint64_t v = default_value.integer;
  if (default_value.plus_node_id) v += node_id;
  return v & mask_bits(bits());
}

std::optional<std::int64_t> ObjectDesc::default_signed_for_node(std::uint8_t node_id) const noexcept {
  const auto raw = default_for_node(node_id);
  if (!raw) return std::nullopt;
  std::uint64_t v = *raw;
  const std::uint32_t b = bits();
  if (is_signed_integer(data_type) && b > 0 && b < 64 && (v >> (b - 1)) != 0) {
    v |= ~mask_bits(b);  // sign-extend
  }
  return static_cast<std::int64_t>(v);
}

const ObjectDesc* DeviceDescription::find(std::uint16_t index, std::uint8_t sub) const noexcept {
  const auto it = std::lower_bound(entries.begin(), entries.end(), std::pair{index, sub},
                                   [](const ObjectDesc& d, const std::pair<std::uint16_t, std::uint8_t>& key) {
                                     return std::pair{d.index, d.sub} < key;
                                   });
  if (it == entries.end() || it->index != index || it->sub != sub) return nullptr;
  return &*it;
}

const ObjectEntry* DeviceDescription::object(std::uint16_t index) const noexcept {
  const auto it = std::lower_bound(objects.begin(), objects.end(), index,
                                   [](const ObjectEntry& o, std::uint16_t key) { return o.index < key; });
  if (it == objects.end() || it->index != index) return nullptr;
  return &*it;
}

// ---------------------------------------------------------------------------
// Errors

namespace {
class EdsCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "cobridge.eds"; }
  std::string message(int ev) const override {
    switch (static_cast<EdsErrc>(ev)) {
      case EdsErrc::kIo: return "cannot read file";
      case EdsErrc::kSyntax: return "syntax error";
      case EdsErrc::kBinaryData: return "binary data";
      case EdsErrc::kDuplicateSection: return "duplicate section";
      case EdsErrc::kDuplicateKey: return "duplicate key";
      case EdsErrc::kMissingSection: return "missing section";
      case EdsErrc::kUnlistedObject: return "object not in any object list";
      case EdsErrc::kSubWithoutParent: return "sub-object without parent object";
      case EdsErrc::kMissingKey: return "missing key";
      case EdsErrc::kBadNumber: return "malformed number";
      case EdsErrc::kBadDataType: return "not a CiA 301 data type";
      case EdsErrc::kBadObjectType: return "not a CiA 306 object type";
      case EdsErrc::kBadAccessType: return "not a CiA 306 access type";
      case EdsErrc::kOutOfRange: return "value out of range";
      case EdsErrc::kInconsistent: return "inconsistent description";
      case EdsErrc::kUnsupported: return "unsupported EDS feature";
      case EdsErrc::kDuplicateIdentity: return "duplicate device identity";
      case EdsErrc::kTooManyErrors: return "too many errors";
    }
    return "unknown EDS error";
  }
};
}  // namespace

const std::error_category& eds_category() noexcept {
  static const EdsCategory category;
  return category;
}

std::error_code make_error_code(EdsErrc e) noexcept { return {static_cast<int>(e), eds_category()}; }

std::string EdsError::to_string() const {
  std::string s = file;
  if (line != 0) {
    s += ':';
    s += std::to_string(line);
    if (column != 0) {
      s += ':';
      s += std::to_string(column);
    }
  }
  s += ": ";
  s += message;
  return s;
}

// ---------------------------------------------------------------------------
// Parser

namespace {

constexpr std::size_t kMaxErrors = 64;
constexpr std::size_t kMaxFileBytes = 4U * 1024U * 1024U;

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return out;
}

bool is_space(char c) noexcept { return c == ' ' || c == '\t'; }

std::string_view trim(std::string_view s) noexcept {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

std::string hex(std::uint64_t v, int digits) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "0x%0*llX", digits, static_cast<unsigned long long>(v));
  return buf;
}

int hex_digit(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// An unsigned integer in CiA 306 notation: decimal, 0x hexadecimal or
// leading-0 octal; no sign.
std::optional<std::uint64_t> parse_unsigned(std::string_view s, bool* is_decimal = nullptr) noexcept {
  if (s.empty()) return std::nullopt;
  unsigned base = 10;
  if (s.size() > 2 && s[0] == '0' && (s[1] == 'x' || s[1] == 'X')) {
    base = 16;
    s.remove_prefix(2);
  } else if (s.size() > 1 && s[0] == '0') {
    base = 8;
    s.remove_prefix(1);
  }
  if (is_decimal != nullptr) *is_decimal = base == 10;
  std::uint64_t v = 0;
  for (char c : s) {
    const int d = hex_digit(c);
    if (d < 0 || static_cast<unsigned>(d) >= base) return std::nullopt;
    if (v > (std::numeric_limits<std::uint64_t>::max() - static_cast<std::uint64_t>(d)) / base) {
      return std::nullopt;  // overflow
    }
    v = v * base + static_cast<std::uint64_t>(d);
  }
  return v;
}

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

  EdsResult run() {
    split();
    interpret();
    EdsResult r;
    if (errors_.empty()) {
      r.description = std::move(desc_);
    } else {
      r.errors = std::move(errors_);
    }
    return r;
  }

 private:
  // -- errors ---------------------------------------------------------------
  void error(std::size_t line, std::size_t column, EdsErrc code, std::string message) {
    if (errors_.size() == kMaxErrors) {
      errors_.push_back({file_, line, 0, EdsErrc::kTooManyErrors,
                         "too many errors; giving up after " + std::to_string(kMaxErrors)});
    }
    if (errors_.size() > kMaxErrors) return;
    errors_.push_back({file_, line, column, code, std::move(message)});
  }

  // -- pass 1: lines into sections ---------------------------------------------
  void split() {
    std::size_t pos = 0;
    std::size_t line_no = 0;
    Section* current = nullptr;
    Section discard;  // receives the lines of a duplicate section
    while (pos < text_.size() && errors_.size() <= kMaxErrors) {
      ++line_no;
      std::size_t end = text_.find('\n', pos);
      if (end == std::string_view::npos) end = text_.size();
      std::string_view raw = text_.substr(pos, end - pos);
      pos = end + 1;
      if (!raw.empty() && raw.back() == '\r') raw.remove_suffix(1);
      if (line_no == 1 && raw.substr(0, 3) == "\xEF\xBB\xBF") raw.remove_prefix(3);  // UTF-8 BOM

      bool binary = false;
      for (std::size_t i = 0; i < raw.size(); ++i) {
        const auto c = static_cast<unsigned char>(raw[i]);
        if ((c < 0x20 && c != '\t') || c == 0x7F) {
          error(line_no, i + 1, EdsErrc::kBinaryData,
                "control character " + hex(c, 2) + " in a text file (allowed: printable text, tab, CR LF)");
          binary = true;
          break;
        }
      }
      if (binary) continue;

      const std::string_view t = trim(raw);
      if (t.empty() || t.front() == ';') continue;
      const std::size_t indent = static_cast<std::size_t>(t.data() - raw.data());

      if (t.front() == '[') {
        if (t.back() != ']') {
          error(line_no, indent + 1, EdsErrc::kSyntax,
                "section header '" + std::string(t) + "' is not closed with ']'");
          current = &discard;
          discard.lines.clear();
          continue;
        }
        const std::string_view name = trim(t.substr(1, t.size() - 2));
        if (name.empty()) {
          error(line_no, indent + 1, EdsErrc::kSyntax, "empty section name '[]'");
          current = &discard;
          continue;
        }
        std::string nl = lower(name);
        const auto it = section_index_.find(nl);
        if (it != section_index_.end()) {
          error(line_no, 0, EdsErrc::kDuplicateSection,
                "duplicate section [" + std::string(name) + "] (first defined at line " +
                    std::to_string(sections_[it->second].line) + ")");
          current = &discard;
          discard.lines.clear();
          continue;
        }
        section_index_.emplace(nl, sections_.size());
        sections_.push_back(Section{std::string(name), std::move(nl), line_no, {}});
        current = &sections_.back();
        continue;
      }

      const std::size_t eq = t.find('=');
      if (eq == std::string_view::npos) {
        error(line_no, indent + 1, EdsErrc::kSyntax,
              "expected '[Section]', 'Key=Value' or '; comment', got '" + std::string(t.substr(0, 40)) + "'");
        continue;
      }
      const std::string_view key = trim(t.substr(0, eq));
      std::string_view value = t.substr(eq + 1);
      // Inline comments need whitespace before ';' so that values such as
      // "a;b" in names survive.
      for (std::size_t i = 1; i < value.size(); ++i) {
        if (value[i] == ';' && is_space(value[i - 1])) {
          value = value.substr(0, i);
          break;
        }
      }
      std::size_t lead = 0;
      while (lead < value.size() && is_space(value[lead])) ++lead;
      value = trim(value);
      if (key.empty()) {
        error(line_no, indent + 1, EdsErrc::kSyntax, "key is empty in '" + std::string(t.substr(0, 40)) + "'");
        continue;
      }
      if (current == nullptr) {
        error(line_no, indent + 1, EdsErrc::kSyntax,
              "'" + std::string(key) + "' appears before the first section header");
        continue;
      }
      std::string kl = lower(key);
      if (current != &discard && current->get(kl) != nullptr) {
        error(line_no, indent + 1, EdsErrc::kDuplicateKey,
              "[" + current->name + "] duplicate key '" + std::string(key) + "' (first at line " +
                  std::to_string(current->get(kl)->line) + ")");
        continue;
      }
      const std::size_t value_col = indent + eq + 2 + lead;
      current->lines.push_back(Line{key, std::move(kl), value, line_no, value_col});
    }
  }

  const Section* section(std::string_view name_lower) const {
    const auto it = section_index_.find(std::string(name_lower));
    return it == section_index_.end() ? nullptr : &sections_[it->second];
  }

  // -- value helpers -------------------------------------------------------------
  std::string where(const Section& s, const Line& l) const { return "[" + s.name + "] " + std::string(l.key) + "=" + std::string(l.value); }

  std::optional<std::uint64_t> number(const Section& s, const Line& l, std::uint64_t max) {
    const auto v = parse_unsigned(l.value);
    if (!v) {
      error(l.line, l.value_column, EdsErrc::kBadNumber,
            where(s, l) + " is not a number (allowed: decimal, 0x hexadecimal, 0 octal)");
      return std::nullopt;
    }
    if (*v > max) {
      error(l.line, l.value_column, EdsErrc::kOutOfRange,
            where(s, l) + " is out of range (allowed: 0.." + std::to_string(max) + ")");
      return std::nullopt;
    }
    return v;
  }

  bool flag(const Section& s, const Line& l) {
    const auto v = number(s, l, 1);
    return v.value_or(0) != 0;
  }

  template <typename T>
  void read_number(const Section& s, std::string_view key, T& out) {
    if (const Line* l = s.get(key)) {
      if (const auto v = number(s, *l, std::numeric_limits<T>::max())) out = static_cast<T>(*v);
    }
  }

  void read_flag(const Section& s, std::string_view key, bool& out) {
    if (const Line* l = s.get(key)) out = flag(s, *l);
  }

  void read_text(const Section& s, std::string_view key, std::string& out) {
    if (const Line* l = s.get(key)) out = std::string(l->value);
  }

  // Parses DefaultValue / LowLimit / HighLimit for `type`.
  EdsValue value(const Section& s, const Line& l, DataType type, bool allow_node_id) {
    EdsValue v;
    v.text = std::string(l.value);
    if (l.value.empty()) return v;
    if (type == DataType::kVisibleString || type == DataType::kOctetString ||
        type == DataType::kUnicodeString || type == DataType::kDomain) {
      v.kind = EdsValue::Kind::kText;
      return v;
    }
    if (is_real(type)) {
      const std::string copy(l.value);
      char* end = nullptr;
      errno = 0;
      const double d = std::strtod(copy.c_str(), &end);
      if (end != copy.c_str() + copy.size() || errno != 0 || !std::isfinite(d)) {
        error(l.line, l.value_column, EdsErrc::kBadNumber, where(s, l) + " is not a real number");
        return v;
      }
      v.kind = EdsValue::Kind::kReal;
      v.real = d;
      return v;
    }
    if (!is_signed_integer(type) && !is_unsigned_integer(type)) {
      // TIME_OF_DAY / TIME_DIFFERENCE: kept as text.
      v.kind = EdsValue::Kind::kText;
      return v;
    }

    static constexpr std::string_view kAllowed =
        " is not a number (allowed: decimal, 0x hexadecimal, 0 octal, $NODEID+number)";
    std::string_view rest = l.value;
    bool negative = false;
    if (rest.front() == '-' || rest.front() == '+') {
      negative = rest.front() == '-';
      rest.remove_prefix(1);
    }
    // Sum of terms: numbers and at most one $NODEID (CiA 306 §4.6.3 allows
    // "$NODEID+0x180"; "0x180+$NODEID" is common in the field).
    std::uint64_t sum = 0;
    bool all_decimal = true;
    bool node = false;
    while (true) {
      const std::size_t plus = rest.find('+');
      const std::string_view term = trim(rest.substr(0, plus));
      if (lower(term) == "$nodeid") {
        if (node || negative) {
          error(l.line, l.value_column, EdsErrc::kBadNumber, where(s, l) + std::string(kAllowed));
          return v;
        }
        node = true;
      } else {
        bool dec = true;
        const auto n = parse_unsigned(term, &dec);
        if (!n || sum > std::numeric_limits<std::uint64_t>::max() - *n) {
          error(l.line, l.value_column, EdsErrc::kBadNumber, where(s, l) + std::string(kAllowed));
          return v;
        }
        all_decimal = all_decimal && dec;
        sum += *n;
      }
      if (plus == std::string_view::npos) break;
      rest = rest.substr(plus + 1);
    }
    if (node && !allow_node_id) {
      error(l.line, l.value_column, EdsErrc::kBadNumber, where(s, l) + ": $NODEID is only allowed in DefaultValue");
      return v;
    }

    // Range of the type. Hex and octal are bit patterns, so a signed type
    // accepts them up to 2^bits - 1; decimal must be in the signed range.
    const std::uint32_t bits = bit_size(type);
    const std::uint64_t umax = mask_bits(bits);
    bool fits = true;
    std::string allowed;
    if (is_signed_integer(type)) {
      const std::uint64_t pos_max = umax >> 1;
      const std::uint64_t neg_max = pos_max + 1;
      fits = negative ? sum <= neg_max : sum <= (all_decimal ? pos_max : umax);
      allowed = "-" + std::to_string(neg_max) + ".." + std::to_string(pos_max);
    } else {
      fits = !negative && sum <= umax;
      allowed = "0.." + std::to_string(umax);
    }
    // $NODEID adds up to 127, which must still fit.
    if (node && fits) fits = sum <= (is_signed_integer(type) ? umax >> 1 : umax) - 127;
    if (!fits) {
      error(l.line, l.value_column, EdsErrc::kOutOfRange,
            where(s, l) + " does not fit " + std::string(to_string(type)) + " (allowed: " + allowed + ")");
      return v;
    }
    v.kind = EdsValue::Kind::kInteger;
    v.plus_node_id = node;
    v.integer = (negative ? (~sum + 1) : sum) & umax;
    return v;
  }

  // -- pass 2 --------------------------------------------------------------------
  struct ListedObject {
    ObjectList list;
    std::size_t line;
    std::string list_name;
    std::string entry;
  };

  void interpret() {
    if (errors_.size() > kMaxErrors) return;
    desc_.source = file_;

    const Section* fi = section("fileinfo");
    const Section* di = section("deviceinfo");
    if (fi == nullptr) error(0, 0, EdsErrc::kMissingSection, "section [FileInfo] is missing (required by CiA 306)");
    if (di == nullptr) error(0, 0, EdsErrc::kMissingSection, "section [DeviceInfo] is missing (required by CiA 306)");
    if (section("mandatoryobjects") == nullptr) {
      error(0, 0, EdsErrc::kMissingSection, "section [MandatoryObjects] is missing (required by CiA 306)");
    }
    if (fi != nullptr) read_file_info(*fi);
    if (di != nullptr) read_device_info(*di);
    if (const Section* cb = section("cobridge")) read_selection(*cb);

    read_list("mandatoryobjects", ObjectList::kMandatory);
    read_list("optionalobjects", ObjectList::kOptional);
    read_list("manufacturerobjects", ObjectList::kManufacturer);
    for (const std::uint16_t required : {std::uint16_t{0x1000}, std::uint16_t{0x1001}}) {
      const auto it = listed_.find(required);
      if (section("mandatoryobjects") != nullptr && (it == listed_.end() || it->second.list != ObjectList::kMandatory)) {
        const Section* m = section("mandatoryobjects");
        error(m->line, 0, EdsErrc::kInconsistent,
              "[" + m->name + "] does not list " + hex(required, 4) + " (CiA 306: 0x1000 and 0x1001 are mandatory)");
      }
    }

    read_objects();
    check_listed_sections();
    std::sort(desc_.objects.begin(), desc_.objects.end(),
              [](const ObjectEntry& a, const ObjectEntry& b) { return a.index < b.index; });
    std::sort(desc_.entries.begin(), desc_.entries.end(), [](const ObjectDesc& a, const ObjectDesc& b) {
      return std::pair{a.index, a.sub} < std::pair{b.index, b.sub};
    });
    check_identity();
    check_selection();
  }

  void read_file_info(const Section& s) {
    auto& f = desc_.file_info;
    read_text(s, "filename", f.file_name);
    read_number(s, "fileversion", f.file_version);
    read_number(s, "filerevision", f.file_revision);
    read_text(s, "edsversion", f.eds_version);
    read_text(s, "description", f.description);
    read_text(s, "creationdate", f.creation_date);
    read_text(s, "createdby", f.created_by);
  }

  void read_device_info(const Section& s) {
    auto& d = desc_.device_info;
    read_text(s, "vendorname", d.vendor_name);
    read_text(s, "productname", d.product_name);
    read_text(s, "ordercode", d.order_code);
    for (const std::string_view required : {std::string_view{"vendornumber"}, std::string_view{"productnumber"}}) {
      if (s.get(required) == nullptr) {
        error(s.line, 0, EdsErrc::kMissingKey,
              "[" + s.name + "] " + (required == "vendornumber" ? "VendorNumber" : "ProductNumber") +
                  " is missing (needed to identify the device)");
      }
    }
    read_number(s, "vendornumber", d.vendor_number);
    read_number(s, "productnumber", d.product_number);
    read_number(s, "revisionnumber", d.revision_number);
    read_flag(s, "baudrate_10", d.baud_10);
    read_flag(s, "baudrate_20", d.baud_20);
    read_flag(s, "baudrate_50", d.baud_50);
    read_flag(s, "baudrate_125", d.baud_125);
    read_flag(s, "baudrate_250", d.baud_250);
    read_flag(s, "baudrate_500", d.baud_500);
    read_flag(s, "baudrate_800", d.baud_800);
    read_flag(s, "baudrate_1000", d.baud_1000);
    read_flag(s, "simplebootupmaster", d.simple_boot_up_master);
    read_flag(s, "simplebootupslave", d.simple_boot_up_slave);
    if (const Line* l = s.get("granularity")) {
      if (const auto v = number(s, *l, 64)) d.granularity = static_cast<std::uint8_t>(*v);
    }
    read_flag(s, "dynamicchannelssupported", d.dynamic_channels_supported);
    read_flag(s, "groupmessaging", d.group_messaging);
    read_number(s, "nrofrxpdo", d.nr_of_rx_pdo);
    read_number(s, "nroftxpdo", d.nr_of_tx_pdo);
    read_flag(s, "lss_supported", d.lss_supported);
  }

  // "0x6020sub0" -> (index, sub)
  static std::optional<std::pair<std::uint16_t, std::uint8_t>> parse_address(std::string_view text) {
    std::string t = lower(text);
    if (t.size() > 2 && t[0] == '0' && t[1] == 'x') t.erase(0, 2);
    const std::size_t p = t.find("sub");
    if (p != 4) return std::nullopt;
    const auto idx = parse_unsigned("0x" + t.substr(0, 4));
    const auto sub = t.size() > 7 && t.size() <= 9 ? parse_unsigned("0x" + t.substr(7)) : std::nullopt;
    if (!idx || !sub || *sub > 0xFF) return std::nullopt;
    return std::pair{static_cast<std::uint16_t>(*idx), static_cast<std::uint8_t>(*sub)};
  }

  void read_selection(const Section& s) {
    auto& sel = desc_.selection;
    read_text(s, "family", sel.family);
    read_text(s, "variant", sel.variant);
    if (const Line* l = s.get("variantprobe")) {
      const auto a = parse_address(l->value);
      if (!a) {
        error(l->line, l->value_column, EdsErrc::kBadNumber,
              where(s, *l) + " is not an object address (allowed: 0xIIIIsubSS, e.g. 0x6020sub0)");
      } else {
        sel.probe_index = a->first;
        sel.probe_sub = a->second;
        probe_line_ = l->line;
      }
      if (const Line* vl = s.get("variantvalue")) {
        if (const auto v = number(s, *vl, std::numeric_limits<std::uint64_t>::max())) sel.probe_value = *v;
      } else {
        error(l->line, 0, EdsErrc::kMissingKey, "[" + s.name + "] VariantProbe needs VariantValue");
      }
    }
    if (const Line* l = s.get("additionalproductnumbers")) {
      std::string_view rest = l->value;
      while (!rest.empty()) {
        const std::size_t comma = rest.find(',');
        const std::string_view item = trim(rest.substr(0, comma));
        const auto v = parse_unsigned(item);
        if (!v || *v > 0xFFFFFFFFU) {
          error(l->line, l->value_column, EdsErrc::kBadNumber,
                where(s, *l) + ": '" + std::string(item) + "' is not a 32-bit number");
        } else {
          sel.additional_products.push_back(static_cast<std::uint32_t>(*v));
        }
        if (comma == std::string_view::npos) break;
        rest = rest.substr(comma + 1);
      }
    }
    read_flag(s, "matchanyproduct", sel.match_any_product);
  }

  void read_list(std::string_view name, ObjectList list) {
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

  // Classifies a section name: object (index), sub-object (index, sub) or other.
  struct Address {
    bool is_object = false;
    bool is_sub = false;
    bool malformed = false;
    std::uint16_t index = 0;
    std::uint8_t sub = 0;
  };

  static Address classify(const std::string& n) {
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

  std::optional<ObjectType> object_type(const Section& s) {
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
  void read_entry(const Section& s, std::uint16_t index, std::uint8_t sub, ObjectType type) {
    ObjectDesc d;
    d.index = index;
    d.sub = sub;
    d.line = s.line;
    bool ok = true;
    if (const Line* l = s.get("parametername")) {
      d.name = std::string(l->value);
    } else {
      error(s.line, 0, EdsErrc::kMissingKey, "[" + s.name + "] ParameterName is missing (required by CiA 306)");
      ok = false;
    }
    const Line* dt = s.get("datatype");
    if (dt == nullptr && type == ObjectType::kDomain) {
      d.data_type = DataType::kDomain;
    } else if (dt == nullptr) {
      error(s.line, 0, EdsErrc::kMissingKey, "[" + s.name + "] DataType is missing (required for a VAR)");
      ok = false;
    } else {
      const auto code = parse_unsigned(dt->value);
      const std::optional<DataType> data_type = code ? canopen::data_type_from_code(*code) : std::nullopt;
      if (!code) {
        error(dt->line, dt->value_column, EdsErrc::kBadNumber,
              where(s, *dt) + " is not a number (allowed: decimal, 0x hexadecimal, 0 octal)");
        ok = false;
      } else if (!data_type) {
        error(dt->line, 0, EdsErrc::kBadDataType,
              where(s, *dt) + " is not a CiA 301 data type (allowed: 0x0001..0x001B" +
                  (*code == 0x0E || *code == 0x17 ? ", except the reserved 0x000E and 0x0017)" : ")"));
        ok = false;
      } else {
        d.data_type = *data_type;
      }
    }
    if (const Line* l = s.get("accesstype")) {
      const std::string a = lower(l->value);
      const auto it = std::find_if(kAccess.begin(), kAccess.end(), [&](const auto& p) { return p.first == a; });
      if (it == kAccess.end()) {
        error(l->line, 0, EdsErrc::kBadAccessType,
              where(s, *l) + " is not a CiA 306 access type (allowed: ro, wo, rw, rwr, rww, const)");
        ok = false;
      } else {
        d.access = it->second;
      }
    } else {
      error(s.line, 0, EdsErrc::kMissingKey, "[" + s.name + "] AccessType is missing (required for a VAR)");
      ok = false;
    }
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
    if (!ok) return;  // values cannot be checked without a valid type

    const std::size_t before = errors_.size();
    const Line* lo = s.get("lowlimit");
    const Line* hi = s.get("highlimit");
    const Line* dv = s.get("defaultvalue");
    if (lo != nullptr) d.low_limit = value(s, *lo, d.data_type, false);
    if (hi != nullptr) d.high_limit = value(s, *hi, d.data_type, false);
    if (dv != nullptr) d.default_value = value(s, *dv, d.data_type, true);
    if (errors_.size() != before) return;

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
    if (seen_.count({index, sub}) != 0) {
      error(s.line, 0, EdsErrc::kDuplicateSection,
            "[" + s.name + "] describes " + hex(index, 4) + " sub " + std::to_string(sub) +
                " again (first at line " + std::to_string(seen_[{index, sub}]) + ")");
      return;
    }
    seen_[{index, sub}] = s.line;
    desc_.entries.push_back(std::move(d));
  }

  void read_objects() {
    // Objects first, so that sub sections can find their parent wherever
    // they appear in the file.
    std::map<std::uint16_t, std::pair<const Section*, ObjectEntry>> objects;
    for (const Section& s : sections_) {
      const Address a = classify(s.name_lower);
      if (!a.is_object) continue;
      ObjectEntry e;
      e.index = a.index;
      e.line = s.line;
      if (const Line* l = s.get("parametername")) e.name = std::string(l->value);
      const auto type = object_type(s);
      if (!type) continue;
      e.type = *type;
      const auto listed = listed_.find(a.index);
      if (listed == listed_.end()) {
        error(s.line, 0, EdsErrc::kUnlistedObject,
              "[" + s.name + "] is not named in [MandatoryObjects], [OptionalObjects] or [ManufacturerObjects]");
      } else {
        e.list = listed->second.list;
      }
      if (e.type == ObjectType::kArray || e.type == ObjectType::kRecord || e.type == ObjectType::kDefStruct) {
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
        read_entry(s, a.index, 0, e.type);
      }
      objects.emplace(a.index, std::pair{&s, e});
    }

    std::map<std::uint16_t, std::size_t> sub_counts;
    for (const Section& s : sections_) {
      const Address a = classify(s.name_lower);
      if (!a.is_sub) continue;
      if (a.malformed) {
        error(s.line, 0, EdsErrc::kSyntax,
              "[" + s.name + "] is not a sub-object section name (allowed: [IIIIsubS], S = 0..FF hexadecimal)");
        continue;
      }
      const auto parent = objects.find(a.index);
      const Section* parent_section = section(lower(hex(a.index, 4).substr(2)));
      if (parent == objects.end()) {
        if (parent_section == nullptr) {
          error(s.line, 0, EdsErrc::kSubWithoutParent,
                "[" + s.name + "] has no parent object section [" + hex(a.index, 4).substr(2) + "]");
        }
        continue;  // the parent exists but was rejected: already reported
      }
      const ObjectType pt = parent->second.second.type;
      if (pt != ObjectType::kArray && pt != ObjectType::kRecord && pt != ObjectType::kDefStruct) {
        error(s.line, 0, EdsErrc::kSubWithoutParent,
              "[" + s.name + "] belongs to [" + parent->second.first->name +
                  "], which is not an ARRAY or RECORD (ObjectType 0x8 or 0x9)");
        continue;
      }
      const auto type = object_type(s);
      if (!type) continue;
      if (*type != ObjectType::kVar) {
        error(s.get("objecttype")->line, 0, EdsErrc::kBadObjectType,
              "[" + s.name + "] ObjectType of a sub-object must be 0x7 (VAR)");
        continue;
      }
      ++sub_counts[a.index];
      read_entry(s, a.index, a.sub, ObjectType::kVar);
    }

    for (auto& [index, pair] : objects) {
      const auto& [s, e] = pair;
      if (e.type == ObjectType::kArray || e.type == ObjectType::kRecord || e.type == ObjectType::kDefStruct) {
        const std::size_t count = sub_counts[index];
        if (s->get("subnumber") != nullptr && count != e.sub_number) {
          error(s->get("subnumber")->line, 0, EdsErrc::kInconsistent,
                "[" + s->name + "] SubNumber=" + std::to_string(e.sub_number) + " but " + std::to_string(count) +
                    " sub-object sections [" + s->name + "subS] exist");
        }
        if (seen_.count({index, 0}) == 0 && count != 0) {
          error(s->line, 0, EdsErrc::kMissingSection,
                "[" + s->name + "] has no sub-index 0 section [" + s->name + "sub0] (CiA 301: highest sub-index)");
        }
      }
      desc_.objects.push_back(e);
    }
  }

  void check_listed_sections() {
    for (const auto& [index, listed] : listed_) {
      if (section(lower(hex(index, 4).substr(2))) == nullptr) {
        error(listed.line, 0, EdsErrc::kMissingSection,
              "[" + listed.list_name + "] " + listed.entry + "=" + hex(index, 4) + " names section [" +
                  hex(index, 4).substr(2) + "], which is missing");
      }
    }
  }

  void check_identity() {
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

  void check_selection() {
    const auto& sel = desc_.selection;
    if (sel.probe_index && desc_.find(*sel.probe_index, sel.probe_sub) == nullptr) {
      error(probe_line_, 0, EdsErrc::kInconsistent,
            "[Cobridge] VariantProbe names " + hex(*sel.probe_index, 4) + " sub " + std::to_string(sel.probe_sub) +
                ", which the file does not describe");
    }
  }

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

}  // namespace

EdsResult parse_eds(std::string_view text, std::string_view file_name) noexcept {
  try {
    return Parser(text, file_name).run();
  } catch (const std::bad_alloc&) {
    EdsResult r;
    r.errors.push_back({std::string(file_name), 0, 0, EdsErrc::kIo, "out of memory while parsing"});
    return r;
  } catch (...) {
    EdsResult r;
    r.errors.push_back({std::string(file_name), 0, 0, EdsErrc::kIo, "internal error while parsing"});
    return r;
  }
}

EdsResult load_eds_file(const std::filesystem::path& path) noexcept {
  try {
    const std::string name = path.string();
    std::ifstream in(path, std::ios::binary);
    if (!in) {
      EdsResult r;
      r.errors.push_back({name, 0, 0, EdsErrc::kIo, "cannot open the file"});
      return r;
    }
    std::string text;
    std::array<char, 65536> buf{};
    while (in) {
      in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
      text.append(buf.data(), static_cast<std::size_t>(in.gcount()));
      if (text.size() > kMaxFileBytes) {
        EdsResult r;
        r.errors.push_back({name, 0, 0, EdsErrc::kIo, "file is larger than 4 MiB; not an EDS"});
        return r;
      }
    }
    if (in.bad()) {
      EdsResult r;
      r.errors.push_back({name, 0, 0, EdsErrc::kIo, "read error"});
      return r;
    }
    return parse_eds(text, name);
  } catch (...) {
    EdsResult r;
    r.errors.push_back({"<eds file>", 0, 0, EdsErrc::kIo, "cannot read the file"});
    return r;
  }
}

}  // namespace cobridge::device
