// AuthFile: the users of the web service's HTTP basic authentication, read
// from a file of "user:password" lines ('#' starts a comment line). The
// file must be readable by the service user only (no group or other
// permission bits): a password readable by others is refused, not used.
// Passwords are compared in time independent of where they differ.
// Thread: load on one thread, then check() from any (read-only).
#pragma once

#include "base/error.hpp"

#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace cobridge::web {

class AuthFile {
 public:
  // Fails with where = the file, the message naming the line when one is
  // wrong; kind kNotFound (cannot be read) or kInvalidArgument (mode, contents).
  [[nodiscard]] Error load(const std::filesystem::path& file);
  [[nodiscard]] bool check(std::string_view user, std::string_view password) const noexcept;
  [[nodiscard]] std::size_t users() const noexcept { return users_.size(); }

 private:
  std::vector<std::pair<std::string, std::string>> users_;
};

}  // namespace cobridge::web
