// AuthFile: the users of the web service's HTTP basic authentication, read
// from a file of "user:hash" lines ('#' starts a comment line), the hash in
// crypt(3) form ("$y$..." yescrypt, "$6$..." SHA-512-crypt; see
// web/password_hash.hpp), as Mosquitto's and Apache's password files hold
// them. A line with a plain-text password is refused, naming file:line, so
// a file written for the old plain format fails loudly instead of letting
// nobody in. The file must be readable by the service user only (no group
// or other permission bits): a file readable by others is refused, not used.
// Thread: load on one thread, then check() from any (read-only).
#pragma once

#include "base/error.hpp"

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace cobridge::web {

class AuthFile {
 public:
  // Fails with kNotFound (cannot be read) where = the file, or
  // kInvalidArgument: the mode (where = the file) or a line (where =
  // "file:line": no colon, a plain-text password, an unusable hash, a user
  // named twice; no user at all: where = the file).
  [[nodiscard]] Error load(const std::filesystem::path& file);
  // True when `user` is in the file and `password` matches its hash. Costs
  // one hash computation whether or not the user exists (an unknown user is
  // checked against another user's hash), so the answer's time does not tell
  // which user names exist.
  [[nodiscard]] bool check(std::string_view user, std::string_view password) const noexcept;
  [[nodiscard]] std::size_t users() const noexcept { return users_.size(); }

 private:
  struct User {
    std::string name;
    std::string hash;
  };
  Error read_line(const std::string& line, const std::string& where);

  std::vector<User> users_;
};

}  // namespace cobridge::web
