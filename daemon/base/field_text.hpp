// Field text: the line format of the gateway's own files (the state file,
// the timeline journal): blank-separated `key=value` fields, values
// percent-encoded where they hold blanks, '%', '=', '#' or control
// characters, so any text fits on one line and a line reads back exactly.
//
// Thread: pure functions, any thread (not used on the hot path).
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "base/result.hpp"

namespace cobridge {

// `text` with every character a field cannot hold as %XX.
[[nodiscard]] std::string escape_field(std::string_view text);
// The text of an escaped value; kInvalidArgument on a bad %-escape.
[[nodiscard]] Result<std::string> unescape_field(std::string_view text);

// One line's fields in order, values unescaped.
using Fields = std::vector<std::pair<std::string, std::string>>;
// The fields of `line`, or kInvalidArgument naming the token that is not
// key=value or holds a bad escape.
[[nodiscard]] Result<Fields> split_fields(std::string_view line);

// At most `max` characters of `text` for a log line or a status message
// about a file that does not read: bytes outside printable ASCII as \xNN,
// "..." when cut. A file's content never reaches a log whole.
[[nodiscard]] std::string log_excerpt(std::string_view text, std::size_t max);

}  // namespace cobridge
