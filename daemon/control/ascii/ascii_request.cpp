#include "control/ascii/ascii_request.hpp"

#include "base/number_text.hpp"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace cobridge::control {
namespace {

struct TypeInfo {
  std::string_view name;
  AsciiType type;
  std::size_t size;  // 0: variable
};
constexpr TypeInfo kTypes[] = {
    {"b", AsciiType::b, 1},     {"i8", AsciiType::i8, 1},   {"i16", AsciiType::i16, 2}, {"i32", AsciiType::i32, 4},
    {"i64", AsciiType::i64, 8}, {"u8", AsciiType::u8, 1},   {"u16", AsciiType::u16, 2}, {"u32", AsciiType::u32, 4},
    {"u64", AsciiType::u64, 8}, {"x8", AsciiType::x8, 1},   {"x16", AsciiType::x16, 2}, {"x32", AsciiType::x32, 4},
    {"x64", AsciiType::x64, 8}, {"r32", AsciiType::r32, 4}, {"r64", AsciiType::r64, 8}, {"vs", AsciiType::vs, 0},
    {"os", AsciiType::os, 0},
};

const TypeInfo* type_named(std::string_view n) {
  for (const auto& t : kTypes) {
    if (t.name == n) return &t;
  }
  return nullptr;
}
const TypeInfo& info(AsciiType type) {
  for (const auto& t : kTypes) {
    if (t.type == type) return t;
  }
  return kTypes[0];
}

// Words separated by blanks; a word starting with '"' runs to the closing
// quote ("" inside is one quote), for vs values.
bool split(std::string_view s, std::vector<std::string>& out) {
  // '\x01' marks a quoted word below; one sent at a word's start passed for
  // that mark (the fuzzer's "\x01" "6" was the i16 6): no request holds one.
  if (s.find('\x01') != std::string_view::npos) return false;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t' || s[i] == '\r')) ++i;
    if (i >= s.size()) break;
    std::string w;
    if (s[i] == '"') {
      ++i;
      bool closed = false;
      while (i < s.size()) {
        if (s[i] == '"' && i + 1 < s.size() && s[i + 1] == '"') {
          w += '"';
          i += 2;
        } else if (s[i] == '"') {
          ++i;
          closed = true;
          break;
        } else {
          w += s[i++];
        }
      }
      if (!closed) return false;
      w.insert(w.begin(), '\x01');  // marks a quoted word
    } else {
      while (i < s.size() && s[i] != ' ' && s[i] != '\t' && s[i] != '\r') w += s[i++];
    }
    out.push_back(std::move(w));
  }
  return true;
}

bool is_number(std::string_view w) {
  std::uint64_t v = 0;
  return parse_unsigned(w, ~0ULL, v);
}

void put_le(std::vector<std::uint8_t>& out, std::uint64_t v, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

// An integer type's value: refused (ERROR: 101) unless the number the text
// denotes is in the type's range, in every form, so that nothing is cut to
// the type's width; hex digits are a magnitude, never a bit pattern
// (base/number_text.hpp: "0xFFFF" is no i16; -1 is "-1" or "-0x1").
// "010", "-07": octal in CANopenNode's gateway (strtol base 0), decimal to
// our parser. The same text must not write two different values depending
// on the gateway, so it is refused rather than guessed.
bool ambiguous_leading_zero(std::string_view v) {
  if (!v.empty() && v.front() == '-') v.remove_prefix(1);
  return v.size() > 1 && v[0] == '0' && v[1] >= '0' && v[1] <= '9';
}

bool encode_integer(AsciiType type, std::string_view v, std::vector<std::uint8_t>& out) {
  if (ambiguous_leading_zero(v)) return false;
  const TypeInfo& t = info(type);
  const unsigned bits = static_cast<unsigned>(t.size * 8);
  if (type == AsciiType::i8 || type == AsciiType::i16 || type == AsciiType::i32 || type == AsciiType::i64) {
    const std::int64_t max = bits == 64 ? INT64_MAX : (std::int64_t{1} << (bits - 1)) - 1;
    std::int64_t s = 0;
    if (!parse_signed(v, -max - 1, max, s)) return false;
    put_le(out, static_cast<std::uint64_t>(s), t.size);
    return true;
  }
  const std::uint64_t max = type == AsciiType::b ? 1 : (bits == 64 ? ~0ULL : (1ULL << bits) - 1);
  std::uint64_t u = 0;
  if (!parse_unsigned(v, max, u)) return false;
  put_le(out, u, t.size);
  return true;
}

// A REAL32/REAL64 value: a finite number the type holds. Out of range
// (1e39 as r32: ERANGE, inf), too small to be kept (1e-50: ERANGE, 0),
// "inf", "nan" and leading blanks are refused: none would be the number typed.
template <typename Real>
bool encode_real(std::string_view v, std::vector<std::uint8_t>& out) {
  const std::string s(v);
  if (s.empty() || std::isspace(static_cast<unsigned char>(s.front())) != 0) return false;
  char* end = nullptr;
  errno = 0;
  Real r{};
  if constexpr (sizeof(Real) == 4) r = std::strtof(s.c_str(), &end);
  else r = std::strtod(s.c_str(), &end);
  if (*end != '\0' || errno == ERANGE || !std::isfinite(r)) return false;
  if constexpr (sizeof(Real) == 4) {
    std::uint32_t u = 0;
    std::memcpy(&u, &r, 4);
    put_le(out, u, 4);
  } else {
    std::uint64_t u = 0;
    std::memcpy(&u, &r, 8);
    put_le(out, u, 8);
  }
  return true;
}

// The bytes of `value` as `type` (CiA 301 §7.1: little-endian).
bool encode(AsciiType type, const std::string& value, std::vector<std::uint8_t>& out) {
  const bool quoted = !value.empty() && value[0] == '\x01';
  const std::string_view v = quoted ? std::string_view(value).substr(1) : std::string_view(value);
  switch (type) {
    case AsciiType::vs:
      out.assign(v.begin(), v.end());
      return true;
    case AsciiType::os:
      return parse_hex_bytes(v, v.size(), out);
    case AsciiType::r32:
      return encode_real<float>(v, out);
    case AsciiType::r64:
      return encode_real<double>(v, out);
    default:
      return encode_integer(type, v, out);
  }
}

AsciiRequest invalid(AsciiRequest r, AsciiError e) {
  r.kind = AsciiRequest::Kind::invalid;
  r.error = e;
  return r;
}

}  // namespace

std::string ascii_ok(std::string_view seq) { return "[" + std::string(seq) + "] OK"; }

std::string ascii_error(std::string_view seq, AsciiError error) {
  return "[" + std::string(seq) + "] ERROR: " + std::to_string(static_cast<unsigned>(error));
}

std::string ascii_abort(std::string_view seq, std::uint32_t abort_code) {
  return "[" + std::string(seq) + "] ERROR: " + hex(abort_code, 8);
}

std::string ascii_line(std::string_view answer) { return std::string(answer) + "\r\n"; }

std::optional<std::string> ascii_format(AsciiType type, std::span<const std::uint8_t> d) {
  char buf[64];
  if (type == AsciiType::none || type == AsciiType::os) return hex_bytes(d);
  if (type == AsciiType::vs) {
    std::string out = "\"";
    for (const auto c : d) {
      if (c == 0) break;
      out += static_cast<char>(c);
      if (c == '"') out += '"';
    }
    return out + "\"";
  }
  const TypeInfo& t = info(type);
  if (d.size() != t.size) return std::nullopt;
  std::uint64_t u = 0;
  for (std::size_t i = 0; i < d.size(); ++i) u |= std::uint64_t{d[i]} << (8 * i);
  const unsigned bits = static_cast<unsigned>(t.size * 8);
  switch (type) {
    case AsciiType::i8: case AsciiType::i16: case AsciiType::i32: case AsciiType::i64: {
      const std::int64_t s = bits == 64 ? static_cast<std::int64_t>(u)
                                        : static_cast<std::int64_t>(u << (64 - bits)) >> (64 - bits);
      std::snprintf(buf, sizeof buf, "%lld", static_cast<long long>(s));
      return std::string(buf);
    }
    case AsciiType::x8: case AsciiType::x16: case AsciiType::x32: case AsciiType::x64:
      return hex(u, static_cast<int>(t.size * 2));
    case AsciiType::r32: {
      float f = 0;
      const auto u32 = static_cast<std::uint32_t>(u);
      std::memcpy(&f, &u32, 4);
      std::snprintf(buf, sizeof buf, "%g", static_cast<double>(f));
      return std::string(buf);
    }
    case AsciiType::r64: {
      double f = 0;
      std::memcpy(&f, &u, 8);
      std::snprintf(buf, sizeof buf, "%g", f);
      return std::string(buf);
    }
    default:
      std::snprintf(buf, sizeof buf, "%llu", static_cast<unsigned long long>(u));
      return std::string(buf);
  }
}

}  // namespace cobridge::control

namespace cobridge::control {
namespace {

AsciiRequest parse_sdo(AsciiRequest r, const std::vector<std::string>& w, std::size_t i, bool write) {
  std::uint64_t index = 0, sub = 0;
  const std::size_t args = w.size() - i;
  if (write ? args != 4 : (args != 2 && args != 3)) return invalid(std::move(r), AsciiError::syntax);
  if (!parse_unsigned(w[i], 0xFFFF, index) || !parse_unsigned(w[i + 1], 0xFF, sub)) return invalid(std::move(r), AsciiError::syntax);
  if (args >= 3) {
    const TypeInfo* t = type_named(w[i + 2]);
    if (t == nullptr) return invalid(std::move(r), w[i + 2] == "d" ? AsciiError::not_supported : AsciiError::syntax);
    r.type = t->type;
  }
  r.command.op = write ? bus::ServiceOp::sdo_download : bus::ServiceOp::sdo_upload;
  r.command.index = static_cast<std::uint16_t>(index);
  r.command.sub = static_cast<std::uint8_t>(sub);
  if (write && !encode(r.type, w[i + 3], r.command.data)) return invalid(std::move(r), AsciiError::syntax);
  if (write && r.command.data.empty()) return invalid(std::move(r), AsciiError::syntax);
  r.kind = write ? AsciiRequest::Kind::write : AsciiRequest::Kind::read;
  return r;
}

AsciiRequest parse_nmt(AsciiRequest r, const std::vector<std::string>& w, std::size_t i) {
  using canopen::NmtCommand;
  const std::string& c = w[i];
  const std::size_t args = w.size() - i;
  if (c == "start" && args == 1) r.command.nmt = NmtCommand::start;
  else if (c == "stop" && args == 1) r.command.nmt = NmtCommand::stop;
  else if ((c == "preop" || c == "preoperational") && args == 1) r.command.nmt = NmtCommand::enter_preop;
  else if (c == "reset" && args == 2 && w[i + 1] == "node") r.command.nmt = NmtCommand::reset_node;
  else if (c == "reset" && args == 2 && (w[i + 1] == "comm" || w[i + 1] == "communication"))
    r.command.nmt = NmtCommand::reset_comm;
  else return invalid(std::move(r), AsciiError::syntax);
  r.command.op = bus::ServiceOp::nmt;
  r.kind = AsciiRequest::Kind::nmt;
  return r;
}

AsciiRequest parse_lss(AsciiRequest r, const std::vector<std::string>& w, std::size_t i) {
  const std::string& c = w[i];
  const std::size_t args = w.size() - i - 1;
  std::uint64_t v[4]{};
  for (std::size_t k = 0; k < args && k < 4; ++k) {
    if (!parse_unsigned(w[i + 1 + k], 0xFFFFFFFF, v[k])) return invalid(std::move(r), AsciiError::syntax);
  }
  auto& s = r.command.lss_steps;
  if (c == "lss_switch_glob" && args == 1 && v[0] <= 1) {
    s.push_back({bus::LssStep::Kind::switch_global, {}, static_cast<std::uint32_t>(v[0])});
  } else if (c == "lss_switch_sel" && args == 4) {
    const canopen::LssAddress a{static_cast<std::uint32_t>(v[0]), static_cast<std::uint32_t>(v[1]),
                                static_cast<std::uint32_t>(v[2]), static_cast<std::uint32_t>(v[3])};
    s.push_back({bus::LssStep::Kind::switch_selective, a, 0});
  } else if (c == "lss_set_node" && args == 1) {
    if (v[0] == 0 || (v[0] > 127 && v[0] != 0xFF)) return invalid(std::move(r), AsciiError::lss_node_id);
    s.push_back({bus::LssStep::Kind::set_node_id, {}, static_cast<std::uint32_t>(v[0])});
  } else if (c == "lss_store" && args == 0) {
    s.push_back({bus::LssStep::Kind::store, {}, 0});
  } else if (c == "lss_inquire_addr" && args <= 1 && v[0] <= 3) {
    constexpr bus::LssStep::Kind kAll[] = {bus::LssStep::Kind::inquire_vendor, bus::LssStep::Kind::inquire_product,
                                      bus::LssStep::Kind::inquire_revision, bus::LssStep::Kind::inquire_serial};
    if (args == 1) s.push_back({kAll[v[0]], {}, 0});
    else for (const auto k : kAll) s.push_back({k, {}, 0});
  } else if (c == "lss_get_node" && args == 0) {
    s.push_back({bus::LssStep::Kind::inquire_node_id, {}, 0});
  } else if (c == "lss_conf_bitrate" || c == "lss_activate_bitrate" || c == "_lss_fastscan" || c == "lss_allnodes") {
    return invalid(std::move(r), AsciiError::not_supported);
  } else {
    return invalid(std::move(r), AsciiError::syntax);
  }
  r.command.op = bus::ServiceOp::lss;
  r.kind = AsciiRequest::Kind::lss;
  return r;
}

AsciiRequest parse_set(AsciiRequest r, const std::vector<std::string>& w, std::size_t i) {
  std::uint64_t v = 0;
  if (w.size() - i != 3 || !parse_unsigned(w[i + 2], 0xFFFFFFFF, v)) return invalid(std::move(r), AsciiError::syntax);
  r.value = static_cast<unsigned>(v);
  if (w[i + 1] == "network") r.kind = AsciiRequest::Kind::set_network;
  else if (w[i + 1] == "node") r.kind = AsciiRequest::Kind::set_node;
  else if (w[i + 1] == "sdo_timeout") r.kind = AsciiRequest::Kind::set_sdo_timeout;
  else return invalid(std::move(r), AsciiError::not_supported);
  if (r.kind == AsciiRequest::Kind::set_node && (v == 0 || v > 127)) return invalid(std::move(r), AsciiError::unsupported_node);
  if (r.kind == AsciiRequest::Kind::set_sdo_timeout && (v < 10 || v > 60000)) return invalid(std::move(r), AsciiError::syntax);
  return r;
}

}  // namespace

AsciiRequest parse_ascii_request(std::string_view line) {
  AsciiRequest r;
  std::vector<std::string> w;
  if (!split(line, w) || w.empty()) return invalid(std::move(r), AsciiError::syntax);
  // [<seq>]: mandatory (CiA 309-3 §4.2: every request carries its sequence number).
  const std::string& s0 = w[0];
  std::uint64_t seq = 0;
  if (s0.size() < 3 || s0.front() != '[' || s0.back() != ']' ||
      !parse_unsigned(std::string_view(s0).substr(1, s0.size() - 2), 0xFFFFFFFF, seq) ||
      std::string_view(s0).substr(1, 2) == "0x")
    return invalid(std::move(r), AsciiError::syntax);
  r.seq = s0.substr(1, s0.size() - 2);
  std::size_t i = 1;
  std::uint64_t a = 0, b = 0;
  const bool n1 = i < w.size() && is_number(w[i]);
  const bool n2 = n1 && i + 1 < w.size() && is_number(w[i + 1]);
  if (i >= w.size()) return invalid(std::move(r), AsciiError::syntax);
  if (n2) {
    if (!parse_unsigned(w[i], 0xFFFF, a)) return invalid(std::move(r), AsciiError::unsupported_net);
    if (!parse_unsigned(w[i + 1], 0xFF, b)) return invalid(std::move(r), AsciiError::unsupported_node);
    r.net = static_cast<unsigned>(a);
    r.node = static_cast<int>(b);
    i += 2;
  } else if (n1) {
    if (!parse_unsigned(w[i], 0xFF, a)) return invalid(std::move(r), AsciiError::unsupported_node);
    r.node = static_cast<int>(a);  // LSS and set: the one number is the net (fixed below)
    i += 1;
  }
  if (i >= w.size()) return invalid(std::move(r), AsciiError::syntax);
  const std::string& c = w[i];
  const bool net_only = c.rfind("lss_", 0) == 0 || c.rfind("_lss", 0) == 0 || c == "set";
  if (net_only && n1 && !n2) {
    r.net = static_cast<unsigned>(r.node);
    r.node = -1;
  } else if (net_only && n2) {
    return invalid(std::move(r), AsciiError::syntax);
  }
  if (c == "r" || c == "read") return parse_sdo(std::move(r), w, i + 1, false);
  if (c == "w" || c == "write") return parse_sdo(std::move(r), w, i + 1, true);
  if (c == "start" || c == "stop" || c == "preop" || c == "preoperational" || c == "reset") return parse_nmt(std::move(r), w, i);
  if (c.rfind("lss_", 0) == 0 || c.rfind("_lss", 0) == 0) return parse_lss(std::move(r), w, i);
  if (c == "set") return parse_set(std::move(r), w, i);
  if (c == "info" && w.size() - i == 2 && w[i + 1] == "version") {
    r.kind = AsciiRequest::Kind::info;
    return r;
  }
  if (c == "help" && !n1) {
    r.kind = AsciiRequest::Kind::help;
    return r;
  }
  if (c == "info") return invalid(std::move(r), AsciiError::not_supported);
  return invalid(std::move(r), AsciiError::not_supported);
}

}  // namespace cobridge::control
