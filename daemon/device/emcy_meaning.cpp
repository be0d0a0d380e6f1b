// The EMCY lookup, family table first: see emcy_meaning.hpp.
#include "device/emcy_meaning.hpp"

#include <cstdio>

namespace cobridge::device {

namespace {

EmcyInfo cia301_info(const canopen::Emcy& e) noexcept {
  EmcyInfo info;
  info.text = canopen::cia301_text(e.error_code);
  info.source = "CiA 301";
  info.error_reset = (e.error_code >> 8) == 0x00;
  return info;
}

const families::EmcyTable* table_of(const families::Family* family) noexcept {
  return family != nullptr ? family->emcy : nullptr;
}

std::string hex(unsigned value, int digits) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%0*X", digits, value);
  return buf;
}

// The data of a CAM or work-area frame (J§1.8.1, E§9.1), as the family laid it out.
std::string detail_text(const families::EmcyDetail& d, std::string_view source) {
  std::string s;
  if (d.kind == families::EmcyDetailKind::none) return s;
  if (d.channel >= 0) s += ", channel " + std::to_string(d.channel);
  if (d.cams >= 0) s += (d.changed_cams ? ", changed CAMs " : ", CAMs ") + hex(static_cast<unsigned>(d.cams), 2);
  s += ", state " + hex(d.state, 2);
  if (d.kind != families::EmcyDetailKind::work_area) return s;
  const std::string bits = canopen::work_area_state_text(d.state);
  if (d.state_listed_as.empty()) return s + " (" + bits + ")";
  return s + " (as 0x6400 bits: " + bits + "; as " + std::string(source) + " list: " + std::string(d.state_listed_as) +
         ")";
}

}  // namespace

std::string_view to_string(EmcyLevel level) noexcept {
  switch (level) {
    case EmcyLevel::unspecified: return "unspecified";
    case EmcyLevel::info: return "Info";
    case EmcyLevel::warn: return "Warn";
    case EmcyLevel::error: return "Error";
    case EmcyLevel::hard: return "Hard";
  }
  return "unknown";
}

EmcyInfo classify_emcy(const families::Family* family, const canopen::Emcy& e) noexcept {
  const families::EmcyTable* table = table_of(family);
  const families::EmcyRow* row =
      table != nullptr ? table->find(e.error_code, e.error_register, e.manufacturer) : nullptr;
  if (row == nullptr) return cia301_info(e);
  EmcyInfo info;
  info.text = row->text;
  info.source = table->source;
  info.level = row->level;
  info.from_manual = true;
  info.error_reset = row->error_reset;
  if (row->position != 0) info.position_value = row->position;
  return info;
}

std::string describe_emcy(const families::Family* family, const canopen::Emcy& e) {
  const EmcyInfo info = classify_emcy(family, e);
  std::string s = "EMCY " + hex(e.error_code, 4) + " " + std::string(info.text) + " (" + std::string(info.source) + ")";
  if (info.level != EmcyLevel::unspecified) s += ", level " + std::string(to_string(info.level));
  const families::EmcyTable* table = info.from_manual ? table_of(family) : nullptr;
  if (table != nullptr && table->detail != nullptr)
    s += detail_text(table->detail(e.error_code, e.manufacturer), table->source);
  if (table != nullptr && table->byte2_is_subcode) {
    s += ", sub-code " + std::to_string(e.error_register) + "/" + std::to_string(e.manufacturer[0]);
  } else {
    s += ", error register " + hex(e.error_register, 2) + " [" + canopen::error_register_text(e.error_register) + "]";
  }
  if (info.position_value) s += ", position reads " + hex(static_cast<std::uint32_t>(*info.position_value), 8);
  // People read this text (log, status, web page): the manual by its title.
  return families::cite_manuals(s);
}

std::optional<std::string_view> error_position_meaning(const families::Family* family, std::int32_t position) noexcept {
  const families::EmcyTable* table = table_of(family);
  if (table == nullptr) return std::nullopt;
  const std::string_view meaning = table->error_position_meaning(position);
  if (meaning.empty()) return std::nullopt;
  return meaning;
}

}  // namespace cobridge::device
