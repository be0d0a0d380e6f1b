// JsonWriter: one JSON text (RFC 8259) built by appending, the one encoder
// of the documents the daemon and the CLI write: the status report, the
// control socket's answers, Error::to_json, the CLI's --json lines and the
// flight recorder's sidecar. Documents this flat read more clearly as calls
// with explicit nesting than as a value tree, and nothing is parsed back.
//
// Strings go through json_quote (control characters and DEL escaped, bytes
// >= 0x80 passed as they are: names and EMCY texts are UTF-8). A number that
// JSON cannot hold (NaN, infinity) is written as null.
// Thread: a value; used by whichever thread builds the text.
#pragma once

#include <concepts>
#include <cstdint>
#include <string>
#include <string_view>

namespace cobridge {

class JsonWriter {
 public:
  JsonWriter& begin_object() { return open('{'); }
  JsonWriter& end_object() { return close('}'); }
  JsonWriter& begin_array() { return open('['); }
  JsonWriter& end_array() { return close(']'); }
  // An object's key; the value written next belongs to it.
  JsonWriter& key(std::string_view k);

  JsonWriter& value(std::string_view s);
  JsonWriter& value(const char* s) { return value(std::string_view(s != nullptr ? s : "")); }
  JsonWriter& value(const std::string& s) { return value(std::string_view(s)); }
  JsonWriter& value(bool b);
  template <std::integral T>
    requires(!std::same_as<T, bool>)
  JsonWriter& value(T n) {
    return raw(std::to_string(n));
  }
  // Seconds, milliseconds and engineering values: to three decimals.
  JsonWriter& value(double d) { return fixed(d, 3); }
  JsonWriter& fixed(double d, int decimals);
  // Every bit of the double (%.17g): what a reader compares exactly.
  JsonWriter& exact(double d);
  JsonWriter& null();
  // A value already encoded as JSON (a nested document, Error::to_json).
  JsonWriter& raw(std::string_view json);

  template <typename T>
  JsonWriter& field(std::string_view k, const T& v) {
    key(k);
    return value(v);
  }

  [[nodiscard]] const std::string& text() const noexcept { return out_; }
  [[nodiscard]] std::string take() { return std::move(out_); }

 private:
  void comma();
  JsonWriter& open(char bracket);
  JsonWriter& close(char bracket);

  std::string out_;
  bool first_ = true;  // no comma before the next value or key
};

}  // namespace cobridge
