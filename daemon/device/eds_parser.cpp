// The EDS parser: the run, errors, numbers and values (CiA 306 §4.6.3).
// See eds_parser.hpp for how the Parser is split.
#include "device/eds_parser.hpp"

#include <algorithm>
#include <cmath>
#include <cerrno>
#include <cstdlib>
#include <limits>

namespace cobridge::device::eds_detail {

EdsResult Parser::run() {
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

// -- errors ---------------------------------------------------------------
void Parser::error(std::size_t line, std::size_t column, EdsErrc code, std::string message) {
  if (errors_.size() == kMaxErrors) {
    errors_.push_back({file_, line, 0, EdsErrc::kTooManyErrors,
                       "too many errors; giving up after " + std::to_string(kMaxErrors)});
  }
  if (errors_.size() > kMaxErrors) return;
  errors_.push_back({file_, line, column, code, std::move(message)});
}

const Section* Parser::section(std::string_view name_lower) const {
  const auto it = section_index_.find(std::string(name_lower));
  return it == section_index_.end() ? nullptr : &sections_[it->second];
}

std::optional<std::uint64_t> Parser::number(const Section& s, const Line& l, std::uint64_t max) {
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

bool Parser::flag(const Section& s, const Line& l) {
  const auto v = number(s, l, 1);
  return v.value_or(0) != 0;
}

void Parser::read_flag(const Section& s, std::string_view key, bool& out) {
  if (const Line* l = s.get(key)) out = flag(s, *l);
}

void Parser::read_text(const Section& s, std::string_view key, std::string& out) {
  if (const Line* l = s.get(key)) out = std::string(l->value);
}

// Parses DefaultValue / LowLimit / HighLimit for `type`.
EdsValue Parser::value(const Section& s, const Line& l, DataType type, bool allow_node_id) {
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
  const auto terms = integer_terms(s, l, allow_node_id);
  if (!terms || !integer_fits(s, l, type, *terms)) return v;
  v.kind = EdsValue::Kind::kInteger;
  v.plus_node_id = terms->node;
  v.integer = (terms->negative ? (~terms->sum + 1) : terms->sum) & mask_bits(bit_size(type));
  return v;
}

// Sum of terms: numbers and at most one $NODEID (CiA 306 §4.6.3 allows
// "$NODEID+0x180"; "0x180+$NODEID" is common in the field).
std::optional<Parser::IntegerTerms> Parser::integer_terms(const Section& s, const Line& l, bool allow_node_id) {
  static constexpr std::string_view kAllowed =
      " is not a number (allowed: decimal, 0x hexadecimal, 0 octal, $NODEID+number)";
  IntegerTerms t;
  std::string_view rest = l.value;
  if (rest.front() == '-' || rest.front() == '+') {
    t.negative = rest.front() == '-';
    rest.remove_prefix(1);
  }
  while (true) {
    const std::size_t plus = rest.find('+');
    const std::string_view term = trim(rest.substr(0, plus));
    if (lower(term) == "$nodeid") {
      if (t.node || t.negative) {
        error(l.line, l.value_column, EdsErrc::kBadNumber, where(s, l) + std::string(kAllowed));
        return std::nullopt;
      }
      t.node = true;
    } else {
      bool dec = true;
      const auto n = parse_unsigned(term, &dec);
      if (!n || t.sum > std::numeric_limits<std::uint64_t>::max() - *n) {
        error(l.line, l.value_column, EdsErrc::kBadNumber, where(s, l) + std::string(kAllowed));
        return std::nullopt;
      }
      t.all_decimal = t.all_decimal && dec;
      t.sum += *n;
    }
    if (plus == std::string_view::npos) break;
    rest = rest.substr(plus + 1);
  }
  if (t.node && !allow_node_id) {
    error(l.line, l.value_column, EdsErrc::kBadNumber, where(s, l) + ": $NODEID is only allowed in DefaultValue");
    return std::nullopt;
  }
  return t;
}

// Range of the type. Hex and octal are bit patterns, so a signed type
// accepts them up to 2^bits - 1; decimal must be in the signed range.
bool Parser::integer_fits(const Section& s, const Line& l, DataType type, const IntegerTerms& t) {
  const std::uint64_t umax = mask_bits(bit_size(type));
  bool fits = true;
  std::string allowed;
  if (is_signed_integer(type)) {
    const std::uint64_t pos_max = umax >> 1;
    const std::uint64_t neg_max = pos_max + 1;
    fits = t.negative ? t.sum <= neg_max : t.sum <= (t.all_decimal ? pos_max : umax);
    allowed = "-" + std::to_string(neg_max) + ".." + std::to_string(pos_max);
  } else {
    fits = !t.negative && t.sum <= umax;
    allowed = "0.." + std::to_string(umax);
  }
  // $NODEID adds up to 127, which must still fit.
  if (t.node && fits) fits = t.sum <= (is_signed_integer(type) ? umax >> 1 : umax) - 127;
  if (!fits) {
    error(l.line, l.value_column, EdsErrc::kOutOfRange,
          where(s, l) + " does not fit " + std::string(to_string(type)) + " (allowed: " + allowed + ")");
  }
  return fits;
}

void Parser::interpret() {
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

}  // namespace cobridge::device::eds_detail
