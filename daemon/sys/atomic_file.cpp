#include "sys/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>

namespace cobridge::sys {

namespace {

std::atomic<unsigned> g_temp_counter{0};

std::error_code errno_code() noexcept { return {errno, std::generic_category()}; }

Error failed(const std::filesystem::path& path, const char* what, std::error_code ec) {
  return Error(Errc::kFailed, std::string(what) + ": " + ec.message(), path.string(), ec);
}

// write() all of `data`, retrying on EINTR and short writes.
bool write_all(int fd, const std::string& data) noexcept {
  std::size_t done = 0;
  while (done < data.size()) {
    const ssize_t n = ::write(fd, data.data() + done, data.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace

Error write_file_atomically(const std::filesystem::path& path, const std::string& text) {
  const auto dir = path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path();
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return failed(path, "cannot create the directory", ec);
  // Unique per process and call, so two writers of one directory never
  // share a temporary file.
  const auto temp = path.string() + ".tmp." + std::to_string(::getpid()) + "." +
                    std::to_string(g_temp_counter.fetch_add(1));
  const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return failed(path, "cannot create the temporary file", errno_code());
  if (!write_all(fd, text) || ::fsync(fd) != 0) {
    const auto err = errno_code();
    ::close(fd);
    ::unlink(temp.c_str());
    return failed(path, "cannot write the temporary file", err);
  }
  if (::close(fd) != 0) {
    const auto err = errno_code();
    ::unlink(temp.c_str());
    return failed(path, "cannot close the temporary file", err);
  }
  if (::rename(temp.c_str(), path.c_str()) != 0) {
    const auto err = errno_code();
    ::unlink(temp.c_str());
    return failed(path, "cannot rename the temporary file", err);
  }
  // The rename itself is only durable once the directory is synced.
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    (void)::fsync(dfd);
    ::close(dfd);
  }
  return {};
}

Error append_to_file(const std::filesystem::path& path, const std::string& text) {
  std::error_code ec;
  if (!path.parent_path().empty()) std::filesystem::create_directories(path.parent_path(), ec);
  if (ec) return failed(path, "cannot create the directory", ec);
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd < 0) return failed(path, "cannot open", errno_code());
  if (!write_all(fd, text)) {
    const auto err = errno_code();
    ::close(fd);
    return failed(path, "cannot append", err);
  }
  if (::close(fd) != 0) return failed(path, "cannot close", errno_code());
  return {};
}

}  // namespace cobridge::sys
