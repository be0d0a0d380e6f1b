// Writing the gateway's own files so that a crash or a power cut leaves the
// old content or the new, never a torn file: a temporary file beside the
// target, fsync, rename over the target, fsync of the directory. Both
// open their files as sys/guarded_file.hpp says: a symbolic link planted
// where the file or the temporary file goes is refused, never followed.
//
// Thread: any thread but the hot path (it blocks on the disk); two writers of
// one directory never share a temporary file.
#pragma once

#include "base/error.hpp"

#include <filesystem>
#include <string>

namespace cobridge::sys {

// Replaces `path` with `text`, creating its directory when missing. A
// failure: kFailed with the errno and what step failed; where = `path`.
// `path` is unchanged then.
[[nodiscard]] Error write_file_atomically(const std::filesystem::path& path, const std::string& text);

// Appends `text` to the regular file `path` (created when missing, 0644) in
// one write; with `sync`, then fdatasync: once it returns, what the file
// holds survives a power cut. A file it created has its directory synced
// too. A symbolic link or another kind of file at `path` is refused.
// kFailed as above.
[[nodiscard]] Error append_to_file(const std::filesystem::path& path, const std::string& text, bool sync = false);

}  // namespace cobridge::sys
