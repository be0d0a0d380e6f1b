// Guarded files: how the gateway opens its own files in directories where
// another account or a bad disk may have left something else. The state
// directory holds the node-ID memory, the timeline journals and the flight
// recorder's captures; anyone who can write there (an operator's mistake, a
// compromised service sharing the group) could plant a symbolic link where a
// file is expected, and the daemon would write, append to or serve the file
// it points at. A damaged disk can leave a file of any size.
//
// So every open here:
//   * refuses a symbolic link at the last component (O_NOFOLLOW: ELOOP), and
//     anything but a regular file (a FIFO would block the open: O_NONBLOCK,
//     then fstat);
//   * creates a new file only where nothing has its name (O_EXCL): a name
//     that exists, a dangling link included, is an error, never reused;
//   * takes at most a bound when reading, from the head or the tail;
// and the writers fsync the file, and the directory after a file was
// created or renamed into it, before the caller says it is written.
//
// Errors: kFailed (kNotFound for a missing file) with the errno as code, the
// path as where, and a message that names what was refused.
//
// Thread: any thread but the hot path (every call may block on the disk).
#pragma once

#include "base/result.hpp"

#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>

namespace cobridge::sys {

// An open file descriptor, closed by the destructor.
class OpenFile {
 public:
  OpenFile() = default;
  explicit OpenFile(int fd) noexcept : fd_(fd) {}
  ~OpenFile();
  OpenFile(OpenFile&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
  OpenFile& operator=(OpenFile&& other) noexcept;
  OpenFile(const OpenFile&) = delete;
  OpenFile& operator=(const OpenFile&) = delete;

  [[nodiscard]] int fd() const noexcept { return fd_; }

 private:
  int fd_ = -1;
};

// Creates `path` for writing (mode 0644, less the umask) only if nothing has
// that name: an existing file or symbolic link is EEXIST, left as it is.
[[nodiscard]] Result<OpenFile> create_new_file(const std::filesystem::path& path);

// Opens the regular file `path` for appending, or creates it (as
// create_new_file) when it is missing; `created` says which.
[[nodiscard]] Result<OpenFile> open_for_append(const std::filesystem::path& path, bool& created);

// Writes all of `data` (retrying short writes and EINTR); `path` names the
// file in the error.
[[nodiscard]] Error write_all(const OpenFile& file, std::string_view data, const std::filesystem::path& path);

// fsync of the file (its data and size on the disk).
[[nodiscard]] Error sync_file(const OpenFile& file, const std::filesystem::path& path);

// fsync of a directory: a name created, renamed or removed in it is on the
// disk. A file system that cannot sync a directory (EINVAL) is not an error.
[[nodiscard]] Error sync_directory(const std::filesystem::path& dir);

// Renames `from` to `to` only if nothing has the name `to` (EEXIST then,
// nothing changed): renameat2(RENAME_NOREPLACE), or link + unlink where the
// file system lacks it.
[[nodiscard]] Error rename_no_replace(const std::filesystem::path& from, const std::filesystem::path& to);

// What read_file_bounded read.
struct FileText {
  std::string text;
  std::uint64_t size = 0;     // the file's size when it was opened
  std::uint64_t skipped = 0;  // bytes left out because the file is over the bound
};
enum class KeepEnd : std::uint8_t { head, tail };

// The regular file `path`, at most `max_bytes` of it: its first bytes
// (head) or its last (tail) when it is larger. A missing file: kNotFound
// (code ENOENT); a symbolic link or another kind of file: kFailed, refused.
[[nodiscard]] Result<FileText> read_file_bounded(const std::filesystem::path& path, std::uint64_t max_bytes,
                                                 KeepEnd keep = KeepEnd::head);

}  // namespace cobridge::sys
