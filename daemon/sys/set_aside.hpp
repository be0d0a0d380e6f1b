// Setting a file aside: the gateway keeps a file of its own that it cannot
// read (bad syntax, binary garbage, an I/O error, a symbolic link) instead
// of writing over it. The file is renamed beside itself,
//   <name>.bad-<UTC time>          e.g. assignments.state.bad-20261128T015512Z
// (-2, -3, ... appended when that name is taken), never over another file and
// never deleted, and the directory is synced, so the bytes are on the disk
// under their new name for the operator's post-mortem or repair.
//
// Thread: any thread but the hot path (renames and syncs on the disk).
#pragma once

#include "base/result.hpp"

#include <chrono>
#include <filesystem>
#include <vector>

namespace cobridge::sys {

// The suffix of a set-aside copy: ".bad-".
inline constexpr const char* kSetAsideMark = ".bad-";

// Renames `path` to its set-aside name for time `now`; returns that name.
// kFailed (errno code, where = `path`) when it cannot be renamed: the file
// is then left where it is.
[[nodiscard]] Result<std::filesystem::path> set_aside(const std::filesystem::path& path,
                                                      std::chrono::system_clock::time_point now);

// The set-aside copies of `path` in its directory, oldest first (their
// names sort by time); none when the directory cannot be read.
[[nodiscard]] std::vector<std::filesystem::path> set_aside_copies(const std::filesystem::path& path);

}  // namespace cobridge::sys
