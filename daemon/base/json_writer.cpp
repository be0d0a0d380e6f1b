#include "base/json_writer.hpp"

#include <array>
#include <cmath>
#include <cstdio>

#include "base/error.hpp"

namespace cobridge {

void JsonWriter::comma() {
  if (!first_) out_ += ',';
  first_ = false;
}

JsonWriter& JsonWriter::open(char bracket) {
  comma();
  out_ += bracket;
  first_ = true;
  return *this;
}

JsonWriter& JsonWriter::close(char bracket) {
  out_ += bracket;
  first_ = false;
  return *this;
}

JsonWriter& JsonWriter::key(std::string_view k) {
  comma();
  out_ += json_quote(k);
  out_ += ':';
  first_ = true;  // the value that follows takes no comma
  return *this;
}

JsonWriter& JsonWriter::value(std::string_view s) {
  comma();
  out_ += json_quote(s);
  return *this;
}

JsonWriter& JsonWriter::value(bool b) { return raw(b ? "true" : "false"); }

JsonWriter& JsonWriter::fixed(double d, int decimals) {
  if (!std::isfinite(d)) return null();
  std::array<char, 64> buf{};
  std::snprintf(buf.data(), buf.size(), "%.*f", decimals, d);
  return raw(buf.data());
}

JsonWriter& JsonWriter::exact(double d) {
  if (!std::isfinite(d)) return null();
  std::array<char, 40> buf{};
  std::snprintf(buf.data(), buf.size(), "%.17g", d);
  return raw(buf.data());
}

JsonWriter& JsonWriter::null() { return raw("null"); }

JsonWriter& JsonWriter::raw(std::string_view json) {
  comma();
  out_ += json;
  return *this;
}

}  // namespace cobridge
