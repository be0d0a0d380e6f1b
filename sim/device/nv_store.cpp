#include "device/nv_store.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <charconv>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string_view>

#include <fcntl.h>
#include <unistd.h>

namespace cobridge::sim {

namespace {

bool parse_hex(std::string_view text, std::uint64_t& out) noexcept {
  if (text.empty()) return false;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), out, 16);
  return ec == std::errc{} && ptr == text.data() + text.size();
}

std::string_view trim(std::string_view s) noexcept {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

void write_image(std::ostringstream& out, const char* header, const NvImage& image) {
  out << header << '\n';
  for (const auto& [key, raw] : image.values())
    out << fmt::format("{:04X}:{:X}={:X}\n", key >> 8, key & 0xFFU, raw);
}

// An I/O failure on `file`: the errno as its code.
Error io_error(const std::filesystem::path& file, const char* what, int err) {
  return Error(Errc::kFailed, what, file.string(), std::error_code(err, std::generic_category()));
}

}  // namespace

std::optional<std::uint64_t> NvImage::get(std::uint16_t index, std::uint8_t sub) const {
  const auto it = values_.find(key(index, sub));
  if (it == values_.end()) return std::nullopt;
  return it->second;
}

Error NvStore::load(NvContents& out) const {
  out = NvContents{};
  if (path_.empty()) return {};
  std::ifstream in(path_);
  if (!in) {
    if (errno == ENOENT) return {};
    return io_error(path_, "cannot open", errno);
  }
  NvImage* image = &out.params;
  std::string line;
  std::size_t number = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::string_view text = trim(line);
    if (text.empty() || text.front() == '#') continue;
    if (text == "[params]") {
      image = &out.params;
      continue;
    }
    if (text == "[history]") {
      image = &out.history;
      continue;
    }
    const auto colon = text.find(':');
    const auto equal = text.find('=');
    std::uint64_t index = 0;
    std::uint64_t sub = 0;
    std::uint64_t raw = 0;
    if (colon == std::string_view::npos || equal == std::string_view::npos || equal < colon ||
        !parse_hex(text.substr(0, colon), index) || !parse_hex(text.substr(colon + 1, equal - colon - 1), sub) ||
        !parse_hex(text.substr(equal + 1), raw) || index > 0xFFFF || sub > 0xFF) {
      return Error(Errc::kInvalidArgument, "expected `index:sub=hex`", fmt::format("{}:{}", path_.string(), number));
    }
    image->set(static_cast<std::uint16_t>(index), static_cast<std::uint8_t>(sub), raw);
  }
  return {};
}

Error NvStore::save(const NvContents& contents) const {
  if (path_.empty()) return {};
  std::ostringstream text;
  text << "# cobridge-sim non-volatile memory; written by the simulated device\n";
  write_image(text, "[params]", contents.params);
  write_image(text, "[history]", contents.history);
  const std::string data = text.str();

  std::error_code ec;
  std::filesystem::create_directories(path_.parent_path(), ec);
  if (ec) return Error(Errc::kFailed, "cannot create directory", path_.parent_path().string(), ec);
  const std::filesystem::path tmp = path_.string() + ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) {
    return io_error(tmp, "cannot create", errno);
  }
  std::size_t done = 0;
  while (done < data.size()) {
    const ssize_t n = ::write(fd, data.data() + done, data.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      return io_error(tmp, "write failed", err);
    }
    done += static_cast<std::size_t>(n);
  }
  // No fsync: the memory outlives the simulator process (a killed simulator
  // leaves the old or the new file, the rename is atomic), not a crash of the
  // host. A flush to disk would stop every device of the simulator's one
  // loop for the disk's time (milliseconds on a loaded host) at each store.
  if (::close(fd) != 0) {
    return io_error(tmp, "close failed", errno);
  }
  if (::rename(tmp.c_str(), path_.c_str()) != 0) {
    return io_error(path_, "rename failed", errno);
  }
  return {};
}

}  // namespace cobridge::sim
