#include "sys/guarded_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>

namespace cobridge::sys {

namespace {

std::error_code errno_code(int e = errno) noexcept { return {e, std::generic_category()}; }

// The message of a failed open: what was refused and why, in words.
Error open_failed(const std::filesystem::path& path, int e) {
  switch (e) {
    case ELOOP:
      return Error(Errc::kFailed, "is a symbolic link; refused (never followed)", path.string(), errno_code(e));
    case EEXIST:
      return Error(Errc::kFailed, "exists already (a file or a symbolic link); not replaced", path.string(),
                   errno_code(e));
    case ENOENT: return Error(Errc::kNotFound, "does not exist", path.string(), errno_code(e));
    default: return Error(Errc::kFailed, "cannot be opened: " + errno_code(e).message(), path.string(), errno_code(e));
  }
}

// A descriptor opened with O_NONBLOCK (so that a FIFO planted there cannot
// block the open) is kept only when it is a regular file.
Result<OpenFile> regular_only(OpenFile file, const std::filesystem::path& path) {
  struct stat st {};
  if (::fstat(file.fd(), &st) != 0) return open_failed(path, errno);
  if (!S_ISREG(st.st_mode))
    return Error(Errc::kFailed, "is not a regular file; refused", path.string(), errno_code(EINVAL));
  const int flags = ::fcntl(file.fd(), F_GETFL);
  if (flags >= 0) (void)::fcntl(file.fd(), F_SETFL, flags & ~O_NONBLOCK);
  return file;
}

// Reads up to `want` bytes at the file's offset into `out`; fewer at the end.
Error read_up_to(int fd, std::uint64_t want, std::string& out, const std::filesystem::path& path) {
  char buffer[65536];
  while (want > 0) {
    const ssize_t n = ::read(fd, buffer, static_cast<std::size_t>(std::min<std::uint64_t>(want, sizeof buffer)));
    if (n < 0) {
      if (errno == EINTR) continue;
      return Error(Errc::kFailed, "read error: " + errno_code().message(), path.string(), errno_code());
    }
    if (n == 0) break;
    out.append(buffer, static_cast<std::size_t>(n));
    want -= static_cast<std::uint64_t>(n);
  }
  return {};
}

}  // namespace

OpenFile::~OpenFile() {
  if (fd_ >= 0) ::close(fd_);
}

OpenFile& OpenFile::operator=(OpenFile&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
  }
  return *this;
}

Result<OpenFile> create_new_file(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) return open_failed(path, errno);
  return OpenFile(fd);
}

Result<OpenFile> open_for_append(const std::filesystem::path& path, bool& created) {
  created = false;
  // Twice at most: a file created by someone else between the two opens is
  // opened the second time.
  for (int attempt = 0; attempt < 2; ++attempt) {
    const int fd = ::open(path.c_str(), O_WRONLY | O_APPEND | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    if (fd >= 0) return regular_only(OpenFile(fd), path);
    if (errno != ENOENT) return open_failed(path, errno);
    Result<OpenFile> made = create_new_file(path);
    if (made.ok()) {
      created = true;
      return made;
    }
    if (made.error().code != errno_code(EEXIST)) return made;
  }
  return open_failed(path, EEXIST);
}

Error write_all(const OpenFile& file, std::string_view data, const std::filesystem::path& path) {
  std::size_t done = 0;
  while (done < data.size()) {
    const ssize_t n = ::write(file.fd(), data.data() + done, data.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return Error(Errc::kFailed, "cannot write: " + errno_code().message(), path.string(), errno_code());
    }
    done += static_cast<std::size_t>(n);
  }
  return {};
}

Error sync_file(const OpenFile& file, const std::filesystem::path& path) {
  if (::fsync(file.fd()) == 0) return {};
  return Error(Errc::kFailed, "cannot sync to the disk: " + errno_code().message(), path.string(), errno_code());
}

Error sync_directory(const std::filesystem::path& dir) {
  const std::filesystem::path d = dir.empty() ? std::filesystem::path(".") : dir;
  const int fd = ::open(d.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return Error(Errc::kFailed, "cannot open the directory: " + errno_code().message(), d.string(), errno_code());
  const OpenFile owner(fd);
  if (::fsync(fd) == 0 || errno == EINVAL) return {};
  return Error(Errc::kFailed, "cannot sync the directory: " + errno_code().message(), d.string(), errno_code());
}

Error rename_no_replace(const std::filesystem::path& from, const std::filesystem::path& to) {
  if (::renameat2(AT_FDCWD, from.c_str(), AT_FDCWD, to.c_str(), RENAME_NOREPLACE) == 0) return {};
  if (errno != EINVAL && errno != ENOSYS)
    return errno == EEXIST ? open_failed(to, EEXIST)
                           : Error(Errc::kFailed, "cannot rename " + from.string() + ": " + errno_code().message(),
                                   to.string(), errno_code());
  // No RENAME_NOREPLACE on this file system: a hard link fails on an existing name too.
  if (::link(from.c_str(), to.c_str()) != 0) {
    if (errno == EEXIST) return open_failed(to, EEXIST);
    return Error(Errc::kFailed, "cannot rename " + from.string() + ": " + errno_code().message(), to.string(),
                 errno_code());
  }
  if (::unlink(from.c_str()) != 0)
    return Error(Errc::kFailed, "renamed, but the old name stays: " + errno_code().message(), from.string(),
                 errno_code());
  return {};
}

Result<FileText> read_file_bounded(const std::filesystem::path& path, std::uint64_t max_bytes, KeepEnd keep) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return open_failed(path, errno);
  Result<OpenFile> file = regular_only(OpenFile(fd), path);
  if (!file.ok()) return file.error();
  struct stat st {};
  if (::fstat(fd, &st) != 0) return open_failed(path, errno);
  FileText out;
  out.size = static_cast<std::uint64_t>(st.st_size);
  if (out.size > max_bytes) {
    out.skipped = out.size - max_bytes;
    if (keep == KeepEnd::tail && ::lseek(fd, static_cast<off_t>(out.skipped), SEEK_SET) < 0)
      return Error(Errc::kFailed, "cannot seek: " + errno_code().message(), path.string(), errno_code());
  }
  out.text.reserve(static_cast<std::size_t>(std::min(out.size, max_bytes)));
  if (Error e = read_up_to(fd, max_bytes, out.text, path)) return e;
  return out;
}

}  // namespace cobridge::sys
