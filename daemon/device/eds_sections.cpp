// The EDS parser, pass 1 (lines into sections) and the header sections
// [FileInfo], [DeviceInfo] and [Cobridge] (CiA 306 §4.3, §4.4).
#include "device/eds_parser.hpp"

#include <algorithm>
#include <cmath>
#include <cerrno>
#include <cstdlib>
#include <limits>

namespace cobridge::device::eds_detail {

// -- pass 1: lines into sections ---------------------------------------------
void Parser::split() {
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
    if (!check_printable(line_no, raw)) continue;

    const std::string_view t = trim(raw);
    if (t.empty() || t.front() == ';') continue;
    const std::size_t indent = static_cast<std::size_t>(t.data() - raw.data());
    if (t.front() == '[')
      current = open_section(line_no, indent, t, discard);
    else
      add_key(line_no, indent, t, current, discard);
  }
}

bool Parser::check_printable(std::size_t line_no, std::string_view raw) {
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const auto c = static_cast<unsigned char>(raw[i]);
    if ((c < 0x20 && c != '\t') || c == 0x7F) {
      error(line_no, i + 1, EdsErrc::kBinaryData,
            "control character " + hex(c, 2) + " in a text file (allowed: printable text, tab, CR LF)");
      return false;
    }
  }
  return true;
}

Section* Parser::open_section(std::size_t line_no, std::size_t indent, std::string_view t, Section& discard) {
  if (t.back() != ']') {
    error(line_no, indent + 1, EdsErrc::kSyntax, "section header '" + std::string(t) + "' is not closed with ']'");
    discard.lines.clear();
    return &discard;
  }
  const std::string_view name = trim(t.substr(1, t.size() - 2));
  if (name.empty()) {
    error(line_no, indent + 1, EdsErrc::kSyntax, "empty section name '[]'");
    return &discard;
  }
  std::string nl = lower(name);
  const auto it = section_index_.find(nl);
  if (it != section_index_.end()) {
    error(line_no, 0, EdsErrc::kDuplicateSection,
          "duplicate section [" + std::string(name) + "] (first defined at line " +
              std::to_string(sections_[it->second].line) + ")");
    discard.lines.clear();
    return &discard;
  }
  section_index_.emplace(nl, sections_.size());
  sections_.push_back(Section{std::string(name), std::move(nl), line_no, {}});
  return &sections_.back();
}

void Parser::add_key(std::size_t line_no, std::size_t indent, std::string_view t, Section* current,
                     const Section& discard) {
  const std::size_t eq = t.find('=');
  if (eq == std::string_view::npos) {
    error(line_no, indent + 1, EdsErrc::kSyntax,
          "expected '[Section]', 'Key=Value' or '; comment', got '" + std::string(t.substr(0, 40)) + "'");
    return;
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
    return;
  }
  if (current == nullptr) {
    error(line_no, indent + 1, EdsErrc::kSyntax, "'" + std::string(key) + "' appears before the first section header");
    return;
  }
  std::string kl = lower(key);
  if (current != &discard && current->get(kl) != nullptr) {
    error(line_no, indent + 1, EdsErrc::kDuplicateKey,
          "[" + current->name + "] duplicate key '" + std::string(key) + "' (first at line " +
              std::to_string(current->get(kl)->line) + ")");
    return;
  }
  const std::size_t value_col = indent + eq + 2 + lead;
  current->lines.push_back(Line{key, std::move(kl), value, line_no, value_col});
}

void Parser::read_file_info(const Section& s) {
  auto& f = desc_.file_info;
  read_text(s, "filename", f.file_name);
  read_number(s, "fileversion", f.file_version);
  read_number(s, "filerevision", f.file_revision);
  read_text(s, "edsversion", f.eds_version);
  read_text(s, "description", f.description);
  read_text(s, "creationdate", f.creation_date);
  read_text(s, "createdby", f.created_by);
}

void Parser::read_device_info(const Section& s) {
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
std::optional<std::pair<std::uint16_t, std::uint8_t>> Parser::parse_address(std::string_view text) {
  std::string t = lower(text);
  if (t.size() > 2 && t[0] == '0' && t[1] == 'x') t.erase(0, 2);
  const std::size_t p = t.find("sub");
  if (p != 4) return std::nullopt;
  const auto idx = parse_unsigned("0x" + t.substr(0, 4));
  const auto sub = t.size() > 7 && t.size() <= 9 ? parse_unsigned("0x" + t.substr(7)) : std::nullopt;
  if (!idx || !sub || *sub > 0xFF) return std::nullopt;
  return std::pair{static_cast<std::uint16_t>(*idx), static_cast<std::uint8_t>(*sub)};
}

void Parser::read_selection(const Section& s) {
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

}  // namespace cobridge::device::eds_detail
