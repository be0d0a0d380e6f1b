#include "pipeline/plugin_trust.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <utility>

namespace cobridge::pipeline {
namespace {

std::string mode_text(mode_t mode) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%04o", static_cast<unsigned>(mode & 07777));
  return buf;
}

Error refused(std::string why) { return Error(Errc::kPermissionDenied, std::move(why)); }

// Why `path` (the file or its directory) is not trusted; kOk when it is.
Error distrust_of(const std::filesystem::path& path, const char* what, uid_t daemon_uid) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    return refused(std::string(what) + " " + path.string() + ": " + std::strerror(errno));
  if (st.st_uid != 0 && st.st_uid != daemon_uid)
    return refused(std::string(what) + " " + path.string() + " is owned by uid " + std::to_string(st.st_uid) +
                   ", neither root nor the daemon's user (uid " + std::to_string(daemon_uid) + ")");
  if ((st.st_mode & (S_IWGRP | S_IWOTH)) != 0)
    return refused(std::string(what) + " " + path.string() + " is writable by group or others (mode " +
                   mode_text(st.st_mode) + ")");
  return {};
}

}  // namespace

Error plugin_distrust(const std::filesystem::path& file, uid_t daemon_uid) {
  struct stat st {};
  if (::stat(file.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) return refused(file.string() + " is not a regular file");
  if (Error e = distrust_of(file, "plugin file", daemon_uid)) return e;
  return distrust_of(file.parent_path(), "plugin directory", daemon_uid);
}

}  // namespace cobridge::pipeline
