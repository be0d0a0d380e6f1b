// Error: the one shape of a failure off the hot path, in every layer.
//
// A failure carries
//   - a kind (Errc): the coarse class a caller acts on; the CLI maps it to an
//     exit code and the control socket / JSON API to a name, the same way;
//   - a precise code (std::error_code, optional): errno, an SDO abort code,
//     an EDS or plugin error code, so nothing the lower layer knew is lost;
//   - a message that says what is wrong and what is allowed;
//   - where: the place it concerns ("file:line:column", "bus 'line1' node 10",
//     "device 'lift': cam 5"), empty when it concerns nothing narrower than the
//     operation.
//
// The hot path never builds one (it counts instead); errors are values, not
// exceptions, so a caller decides whether to log, retry or report.
//
// Thread contract: plain value type; any thread.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>

namespace cobridge {

// The coarse classes. Their numbers are the CLI's exit codes
// (docs/operations.md, "Exit codes"); keep them stable.
enum class Errc : std::uint8_t {
  kOk = 0,
  kFailed = 1,           // the operation ran and failed (device refused, protocol error, I/O)
  kInvalidArgument = 2,  // bad input: argument, configuration, request, file contents
  kTimeout = 3,          // no answer within the bound
  kPermissionDenied = 4, // the caller may not do this (control socket groups, writes disabled)
  kUnavailable = 5,      // the bus, daemon or device is not there or not ready; retry may work
  kNotFound = 6,         // no such bus, node, device, object or plugin
  kUnsupported = 7,      // understood, but not supported by this device or build
  kInternal = 8,         // a bug: an invariant did not hold
};

// "ok", "failed", "invalid_argument", ... (the JSON "code" field).
[[nodiscard]] std::string_view name(Errc kind) noexcept;
// The CLI exit code of a kind (its number).
[[nodiscard]] constexpr int exit_code(Errc kind) noexcept { return static_cast<int>(kind); }

struct Error {
  Errc kind = Errc::kOk;
  std::error_code code;  // precise cause; may be empty
  std::string message;
  std::string where;

  Error() = default;
  Error(Errc k, std::string msg, std::string place = {}, std::error_code precise = {})
      : kind(k), code(precise), message(std::move(msg)), where(std::move(place)) {}

  [[nodiscard]] bool ok() const noexcept { return kind == Errc::kOk; }
  explicit operator bool() const noexcept { return kind != Errc::kOk; }  // true = failed

  // "where: message" (just "message" when where is empty).
  [[nodiscard]] std::string to_string() const;
  // {"code":"timeout","where":"...","message":"...","detail":{"category":"sdo","value":84082688}}
  // ("detail" only when code is set). One encoder for the control socket,
  // the CLI's --json and the web API.
  [[nodiscard]] std::string to_json() const;
};

// JSON string literal with quotes and escapes (RFC 8259; control characters
// and DEL as \u00XX), for the encoders
// that embed an Error in a larger document.
[[nodiscard]] std::string json_quote(std::string_view text);

}  // namespace cobridge
