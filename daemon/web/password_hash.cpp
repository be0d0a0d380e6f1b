#include "web/password_hash.hpp"

#include <crypt.h>

#include <array>
#include <cstring>
#include <memory>

namespace cobridge::web {
namespace {

// libxcrypt's working state (32 KiB): on the heap, one per call, wiped after
// use since it held the password and its intermediate values.
struct CryptState {
  crypt_data data{};
  ~CryptState() { ::explicit_bzero(&data, sizeof data); }
};

}  // namespace

bool equal_constant_time(std::string_view a, std::string_view b) noexcept {
  unsigned diff = a.size() == b.size() ? 0U : 1U;
  for (std::size_t i = 0; i < a.size(); ++i)
    diff |= static_cast<unsigned>(static_cast<unsigned char>(a[i]) ^
                                  static_cast<unsigned char>(i < b.size() ? b[i] : '\0'));
  return diff == 0;
}

std::string hash_problem(const std::string& hash) {
  if (hash.empty() || hash[0] != '$')
    return "plain-text password; make a hash with `cobridged --hash-password` (or `mkpasswd -m yescrypt`, "
           "`openssl passwd -6`)";
  switch (::crypt_checksalt(hash.c_str())) {
    case CRYPT_SALT_OK: return {};
    case CRYPT_SALT_METHOD_LEGACY:
    case CRYPT_SALT_TOO_CHEAP:
      return "a legacy or too cheap hash method; make a yescrypt hash with `cobridged --hash-password`";
    case CRYPT_SALT_METHOD_DISABLED: return "a hash method this libcrypt has disabled";
    default: return "not a crypt(3) hash this libcrypt knows (\"$y$...\" yescrypt or \"$6$...\" SHA-512-crypt)";
  }
}

bool verify_password(std::string_view password, const std::string& hash) noexcept {
  try {
    if (!hash_problem(hash).empty()) return false;
    const std::string phrase(password);  // crypt wants it NUL-terminated
    auto state = std::make_unique<CryptState>();
    const char* out = ::crypt_rn(phrase.c_str(), hash.c_str(), &state->data, sizeof state->data);
    return out != nullptr && equal_constant_time(out, hash);
  } catch (...) {  // std::bad_alloc: not verified
    return false;
  }
}

Error hash_password(std::string_view password, std::string& hash) {
  std::array<char, CRYPT_GENSALT_OUTPUT_SIZE> salt{};
  // Count 0: libxcrypt's default cost; nullptr: random bytes from the kernel.
  if (::crypt_gensalt_rn("$y$", 0, nullptr, 0, salt.data(), static_cast<int>(salt.size())) == nullptr)
    return Error(Errc::kFailed, std::string("cannot make a yescrypt salt: ") + std::strerror(errno));
  const std::string phrase(password);
  auto state = std::make_unique<CryptState>();
  const char* out = ::crypt_rn(phrase.c_str(), salt.data(), &state->data, sizeof state->data);
  if (out == nullptr) return Error(Errc::kFailed, std::string("cannot hash the password: ") + std::strerror(errno));
  hash = out;
  return {};
}

}  // namespace cobridge::web
