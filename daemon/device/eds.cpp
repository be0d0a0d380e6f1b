// CiA 306 EDS: the description types and the two entry points, parse_eds
// and load_eds_file. The parser itself is eds_parser.hpp and its files;
// errors are eds_error.cpp.
#include "device/eds.hpp"

#include <algorithm>
#include <array>
#include <fstream>
#include <new>
#include <utility>

#include "device/eds_parser.hpp"

namespace cobridge::device {

// ---------------------------------------------------------------------------
// Data types and access types

using eds_detail::kAccess;
using eds_detail::mask_bits;

std::string_view to_string(AccessType type) noexcept {
  for (const auto& [name, value] : kAccess) {
    if (value == type) return name;
  }
  return "?";
}

// ---------------------------------------------------------------------------
// Lookups

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
// Entry points

using eds_detail::kMaxFileBytes;
using eds_detail::Parser;

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
