#include "sys/atomic_file.hpp"

#include "sys/guarded_file.hpp"

#include <unistd.h>

#include <atomic>
#include <cerrno>

namespace cobridge::sys {

namespace {

std::atomic<unsigned> g_temp_counter{0};

Error failed(const std::filesystem::path& path, const char* what, const Error& why) {
  return Error(Errc::kFailed, std::string(what) + ": " + why.to_string(), path.string(), why.code);
}

}  // namespace

Error write_file_atomically(const std::filesystem::path& path, const std::string& text) {
  const auto dir = path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path();
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return Error(Errc::kFailed, "cannot create the directory: " + ec.message(), path.string(), ec);
  // Unique per process and call, so two writers of one directory never
  // share a temporary file; created with O_EXCL, so a name someone planted
  // there (a link to another file) is refused, never written through.
  const std::filesystem::path temp = path.string() + ".tmp." + std::to_string(::getpid()) + "." +
                                     std::to_string(g_temp_counter.fetch_add(1));
  Result<OpenFile> file = create_new_file(temp);
  if (!file.ok()) return failed(path, "cannot create the temporary file", file.error());
  Error e = write_all(*file, text, temp);
  if (!e) e = sync_file(*file, temp);
  file = OpenFile();  // closed before the rename
  if (e) {
    ::unlink(temp.c_str());
    return failed(path, "cannot write the temporary file", e);
  }
  // rename() replaces the name itself: a symbolic link at `path` is
  // replaced, never followed.
  if (::rename(temp.c_str(), path.c_str()) != 0) {
    const std::error_code err{errno, std::generic_category()};
    ::unlink(temp.c_str());
    return Error(Errc::kFailed, "cannot rename the temporary file: " + err.message(), path.string(), err);
  }
  // The rename itself is only durable once the directory is synced.
  if (Error d = sync_directory(dir)) return failed(path, "written, but its directory not synced", d);
  return {};
}

Error append_to_file(const std::filesystem::path& path, const std::string& text, bool sync) {
  std::error_code ec;
  if (!path.parent_path().empty()) std::filesystem::create_directories(path.parent_path(), ec);
  if (ec) return Error(Errc::kFailed, "cannot create the directory: " + ec.message(), path.string(), ec);
  bool created = false;
  Result<OpenFile> file = open_for_append(path, created);
  if (!file.ok()) return file.error();
  if (Error e = write_all(*file, text, path)) return e;
  if (sync && ::fdatasync(file->fd()) != 0) {
    const std::error_code err{errno, std::generic_category()};
    return Error(Errc::kFailed, "cannot sync to the disk: " + err.message(), path.string(), err);
  }
  if (created) return sync_directory(path.parent_path());
  return {};
}

}  // namespace cobridge::sys
