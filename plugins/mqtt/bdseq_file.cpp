#include "bdseq_file.hpp"

#include <cobridge/plugin.h>

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace cobridge::mqtt {
namespace {

std::string folder_of(const std::string& path) {
  const std::size_t slash = path.rfind('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

// Writes `text` to `path` durably: temp file, fsync, rename, fsync of the folder.
std::string write_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0640);
  if (fd < 0) return "cannot create " + tmp + ": " + std::strerror(errno);
  const bool written = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
  const int write_errno = errno;
  const bool synced = written && ::fsync(fd) == 0;
  ::close(fd);
  if (!synced) {
    ::unlink(tmp.c_str());
    return "cannot write " + tmp + ": " + std::strerror(written ? errno : write_errno);
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int e = errno;
    ::unlink(tmp.c_str());
    return "cannot rename " + tmp + " to " + path + ": " + std::strerror(e);
  }
  const int dir = ::open(folder_of(path).c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir >= 0) {
    (void)::fsync(dir);  // the rename itself made durable
    ::close(dir);
  }
  return {};
}

}  // namespace

std::optional<std::uint8_t> parse_bdseq(const std::string& text) noexcept {
  std::size_t n = text.size();
  if (n != 0 && text[n - 1] == '\n') --n;
  if (n == 0 || n > 3) return std::nullopt;
  unsigned v = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (text[i] < '0' || text[i] > '9') return std::nullopt;
    v = v * 10u + static_cast<unsigned>(text[i] - '0');
  }
  if (v > 255u) return std::nullopt;
  return static_cast<std::uint8_t>(v);
}

BdSeqFile::BdSeqFile(std::string path, LogFn log) : path_(std::move(path)), log_(std::move(log)) {}

void BdSeqFile::load() {
  const std::lock_guard lock(mutex_);
  last_.reset();
  if (path_.empty()) return;
  const int fd = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    if (errno != ENOENT)
      log_(COBRIDGE_LOG_WARN, "bdSeq file " + path_ + " cannot be read (" + std::strerror(errno) + "); bdSeq starts at 0");
    return;
  }
  char buf[64];
  const ssize_t n = ::read(fd, buf, sizeof buf);
  ::close(fd);
  const std::string text(buf, n > 0 ? static_cast<std::size_t>(n) : 0u);
  last_ = parse_bdseq(text);
  if (last_) return;
  const std::string bad = path_ + ".bad";
  std::string shown = text.substr(0, 40);
  for (char& c : shown)
    if (c < ' ' || c > '~') c = '?';
  const bool kept = ::rename(path_.c_str(), bad.c_str()) == 0;
  log_(COBRIDGE_LOG_ERROR, "bdSeq file " + path_ + " is damaged (it holds \"" + shown +
                               "\", not a number 0..255): " + (kept ? "set aside as " + bad : "it could not be set aside") +
                               "; bdSeq starts at 0, and a host may take a late NDEATH of the previous run for this one's");
}

std::optional<std::uint8_t> BdSeqFile::last() const {
  const std::lock_guard lock(mutex_);
  return last_;
}

std::uint8_t BdSeqFile::next(std::optional<std::uint8_t> at_least_after) {
  const std::lock_guard lock(mutex_);
  std::uint8_t v = last_ ? static_cast<std::uint8_t>(*last_ + 1u) : 0u;
  // The pair's other gateway used `at_least_after`: continue from it, so the
  // edge node's sessions count on as one.
  if (at_least_after) v = static_cast<std::uint8_t>(*at_least_after + 1u);
  last_ = v;
  save(v);
  return v;
}

void BdSeqFile::save(std::uint8_t value) {
  if (path_.empty()) return;
  const std::string error = write_atomically(path_, std::to_string(value) + "\n");
  if (error.empty()) {
    write_failed_logged_ = false;
    return;
  }
  if (!write_failed_logged_)
    log_(COBRIDGE_LOG_ERROR, "bdSeq " + std::to_string(value) + " not persisted (" + error +
                                 "): after a restart bdSeq may repeat");
  write_failed_logged_ = true;
}

}  // namespace cobridge::mqtt
