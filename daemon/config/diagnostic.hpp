// Diagnostic: one problem found in the configuration file, with the place it
// was found (file, 1-based line and column; 0 when the problem concerns the
// whole file, e.g. it cannot be read) and a message that says what is wrong
// and what is allowed.
//
// Kept beside cobridge::Error because the loader needs the place
// as numbers: it reports every problem of a file sorted by line and column,
// and the tests compare places. Every layer above reports it as an Error
// (to_error), so the CLI, the daemon and the web API print one shape.
//
// Thread contract: plain value; created by the loader on the start-up /
// reload thread.
#pragma once

#include "base/error.hpp"

#include <cstdint>
#include <string>

namespace cobridge::config {

struct Diagnostic {
  std::string file;
  std::uint32_t line = 0;
  std::uint32_t column = 0;
  std::string message;

  friend bool operator==(const Diagnostic&, const Diagnostic&) = default;
};

// "file:line:column: message" (compiler style, so editors can jump to it);
// "file: message" when the line is unknown.
[[nodiscard]] std::string to_string(const Diagnostic& d);

// The project's one error shape: kind kInvalidArgument (the configuration is
// the caller's input), where = "file:line:column" ("file" when the line is
// unknown), the message unchanged. to_error(d).to_string() == to_string(d).
[[nodiscard]] Error to_error(const Diagnostic& d);

}  // namespace cobridge::config
