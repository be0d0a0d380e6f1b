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
    // Trailing blanks (an editor's, a CRLF file's) are no part of a hash:
    // kept, they would make the line's password never match.
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    if (Error e = read_line(line, file.string() + ":" + std::to_string(n))) {
      users_.clear();
      return e;
    }
  }
  if (users_.empty()) return fail("no user:hash line");
  return {};
}

Error AuthFile::read_line(const std::string& line, const std::string& where) {
  const auto colon = line.find(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == line.size())
    return Error(Errc::kInvalidArgument, "expected user:hash", where);
  User user{line.substr(0, colon), line.substr(colon + 1)};
  if (const std::string problem = hash_problem(user.hash); !problem.empty())
    return Error(Errc::kInvalidArgument, "user \"" + user.name + "\": " + problem, where);
  for (const User& u : users_) {
    if (u.name == user.name) return Error(Errc::kInvalidArgument, "user \"" + user.name + "\" is named twice", where);
  }
  users_.push_back(std::move(user));
  return {};
}

bool AuthFile::check(std::string_view user, std::string_view password) const noexcept {
  if (users_.empty()) return false;
  const User* found = nullptr;
  for (const User& u : users_) found = equal_constant_time(u.name, user) ? &u : found;
  const bool match = verify_password(password, found != nullptr ? found->hash : users_.front().hash);
  return match && found != nullptr;
}

}  // namespace cobridge::web
