#include "sys/set_aside.hpp"

#include "sys/guarded_file.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <ctime>

namespace cobridge::sys {

namespace {

// 20261128T015512Z: sortable, free of ':' (a file name on any system).
std::string utc_stamp(std::chrono::system_clock::time_point now) {
  const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char text[80];  // room for any int the fields hold, as the compiler counts
  std::snprintf(text, sizeof text, "%04d%02d%02dT%02d%02d%02dZ", utc.tm_year + 1900, utc.tm_mon + 1, utc.tm_mday,
                utc.tm_hour, utc.tm_min, utc.tm_sec);
  return text;
}

}  // namespace

Result<std::filesystem::path> set_aside(const std::filesystem::path& path, std::chrono::system_clock::time_point now) {
  const std::string base = path.string() + kSetAsideMark + utc_stamp(now);
  // A second bad file within the same second (a reload right after a start)
  // gets the next free number; 100 taken means something else is wrong.
  for (int n = 1; n <= 100; ++n) {
    const std::filesystem::path aside = n == 1 ? base : base + "-" + std::to_string(n);
    const Error e = rename_no_replace(path, aside);
    if (e.code == std::error_code(EEXIST, std::generic_category())) continue;
    if (e) return Error(Errc::kFailed, "cannot be set aside: " + e.message, path.string(), e.code);
    // Renamed is what counts: a directory that cannot be synced (a
    // read-only remount) does not make the copy less kept.
    (void)sync_directory(path.parent_path());
    return aside;
  }
  return Error(Errc::kFailed, "cannot be set aside: 100 copies of this second exist already", path.string(),
               std::error_code(EEXIST, std::generic_category()));
}

std::vector<std::filesystem::path> set_aside_copies(const std::filesystem::path& path) {
  std::vector<std::filesystem::path> out;
  const std::string prefix = path.filename().string() + kSetAsideMark;
  const std::filesystem::path dir = path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path();
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.size() > prefix.size() && name.compare(0, prefix.size(), prefix) == 0) out.push_back(entry.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace cobridge::sys
