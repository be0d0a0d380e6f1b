#include "web/auth_file.hpp"

#include "web/password_hash.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <fstream>

namespace cobridge::web {

Error AuthFile::load(const std::filesystem::path& file) {
  auto fail = [&](const std::string& what, Errc kind = Errc::kInvalidArgument, int err = 0) {
    return Error(kind, what, file.string(), err != 0 ? std::error_code(err, std::system_category()) : std::error_code{});
  };
  users_.clear();
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0) {
    const int err = errno;
    return fail(std::strerror(err), Errc::kNotFound, err);
  }
  if (!S_ISREG(st.st_mode)) return fail("not a regular file");
  if ((st.st_mode & 077) != 0)
    return fail("readable or writable by group or others (mode " + std::to_string((st.st_mode >> 6) & 7) +
                std::to_string((st.st_mode >> 3) & 7) + std::to_string(st.st_mode & 7) + "); chmod 600 it");
  std::ifstream in(file);
  if (!in) {
    const int err = errno;
    return fail(std::strerror(err), Errc::kNotFound, err);
  }
  std::string line;
  std::size_t n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos || colon == 0 || colon + 1 == line.size())
      return fail("line " + std::to_string(n) + ": expected user:password");
    users_.emplace_back(line.substr(0, colon), line.substr(colon + 1));
  }
  if (users_.empty()) return fail("no user:password line");
  return {};
}

bool AuthFile::check(std::string_view user, std::string_view password) const noexcept {
  bool ok = false;
  for (const auto& [u, p] : users_) ok |= equal_constant_time(u, user) & equal_constant_time(p, password);
  return ok;
}

}  // namespace cobridge::web
