// Password hashes in crypt(3) form, as Mosquitto's and Apache's password
// files hold them: "$y$..." (yescrypt, Debian 12's default for login
// passwords) or "$6$..." (SHA-512-crypt, what `openssl passwd -6` makes),
// verified and made with libxcrypt (libcrypt-dev, -lcrypt). The web
// service's auth file holds these, never a password itself.
// Thread: any; every call has its own libxcrypt state (crypt_rn).
#pragma once

#include "base/error.hpp"

#include <string>
#include <string_view>

namespace cobridge::web {

// Why a stored hash cannot be used, or "" when it can: a plain-text password
// (no "$" prefix), a method libxcrypt does not know or has disabled, or a
// legacy one (DES, MD5-crypt) that is too weak to accept.
[[nodiscard]] std::string hash_problem(const std::string& hash);

// True when `password` hashes to `hash` (compared in constant time).
// False for a hash that hash_problem() refuses.
[[nodiscard]] bool verify_password(std::string_view password, const std::string& hash) noexcept;

// A new yescrypt hash of `password` with a random salt and libxcrypt's
// default cost. Fails (kFailed) only when libxcrypt cannot make a salt or
// a hash.
[[nodiscard]] Error hash_password(std::string_view password, std::string& hash);

// `a` == `b`, in time that depends on their lengths only, not on where they differ.
[[nodiscard]] bool equal_constant_time(std::string_view a, std::string_view b) noexcept;

}  // namespace cobridge::web
