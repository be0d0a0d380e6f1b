// Password hashes: the auth file holds crypt(3) hashes,
// checked with libxcrypt; a plain-text password or a legacy method is refused.
#include "web/password_hash.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

using cobridge::web::equal_constant_time;
using cobridge::web::hash_password;
using cobridge::web::hash_problem;
using cobridge::web::verify_password;
using ::testing::HasSubstr;
using ::testing::StartsWith;

namespace {

// Made for these tests with libxcrypt (crypt_gensalt_rn("$y$", 0,
// "cobridge-test-01") then crypt_rn) and with `openssl passwd -6 -salt
// cobridgeSalt 'correct horse'` (same hash from both).
const std::string kYescrypt = "$y$j9T$XxaMmZ4NbJK9oJqQop0Al.$wXeW/tZvuWxWR7ojIaisTAnMq9/UDFd7.bFGmPDXT0B";
const std::string kSha512 =
    "$6$cobridgeSalt$QZXYlZyOar4hrNDgTDFsIOJ8PzQgmL9U7T38YaodVkCBZ4/Nry9sYyaKlhJKYGciiHYkWSY//7qomfLdyUWHM1";

// What a shell command prints (its first line), "" when it cannot run.
std::string first_line_of(const std::string& command) {
  std::FILE* p = ::popen(command.c_str(), "r");
  if (p == nullptr) return {};
  char buf[512] = {};
  std::string out = std::fgets(buf, sizeof buf, p) != nullptr ? buf : "";
  ::pclose(p);
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return out;
}

TEST(PasswordHash, YescryptAndSha512CryptVectors) {
  EXPECT_EQ(hash_problem(kYescrypt), "");
  EXPECT_EQ(hash_problem(kSha512), "");
  EXPECT_TRUE(verify_password("correct horse", kYescrypt));
  EXPECT_TRUE(verify_password("correct horse", kSha512));
  for (const char* wrong : {"correct horse ", "correct hors", "Correct horse", "", "correct horse\n"}) {
    EXPECT_FALSE(verify_password(wrong, kYescrypt)) << wrong;
    EXPECT_FALSE(verify_password(wrong, kSha512)) << wrong;
  }
}

// A hash made at test time by another implementation (OpenSSL's SHA-512-crypt).
TEST(PasswordHash, OpensslPasswd6HashVerifies) {
  const std::string hash = first_line_of("openssl passwd -6 -stdin <<'EOF'\ns3cret:with colon\nEOF\n");
  ASSERT_FALSE(hash.empty()) << "openssl not found (Debian package openssl: scripts/setup-deps)";
  ASSERT_THAT(hash, StartsWith("$6$"));
  EXPECT_TRUE(verify_password("s3cret:with colon", hash));
  EXPECT_FALSE(verify_password("s3cret", hash));
}

TEST(PasswordHash, MadeHashesAreYescryptWithTheirOwnSalt) {
  std::string a;
  std::string b;
  ASSERT_FALSE(hash_password("hunter2", a));
  ASSERT_FALSE(hash_password("hunter2", b));
  EXPECT_THAT(a, StartsWith("$y$"));
  EXPECT_NE(a, b) << "a random salt each time";
  EXPECT_TRUE(verify_password("hunter2", a));
  EXPECT_TRUE(verify_password("hunter2", b));
  EXPECT_FALSE(verify_password("hunter3", a));
}

TEST(PasswordHash, PlainTextAndLegacyMethodsAreRefused) {
  EXPECT_THAT(hash_problem("s3cret"), HasSubstr("plain-text password"));
  EXPECT_THAT(hash_problem("s3cret"), HasSubstr("--hash-password"));
  EXPECT_THAT(hash_problem(""), HasSubstr("plain-text password"));
  // DES ("ab" salt) and MD5-crypt: crypt(3) would take them, we do not.
  EXPECT_THAT(hash_problem("abJnggxhB/yWI"), HasSubstr("plain-text"));
  EXPECT_THAT(hash_problem("$1$saltsalt$2vnaRpHa6Jxjz5n83ok8Z0"), HasSubstr("legacy"));
  EXPECT_THAT(hash_problem("$zz$nonsense"), HasSubstr("not a crypt(3) hash"));
  // A password that is its own "hash" never verifies.
  EXPECT_FALSE(verify_password("s3cret", "s3cret"));
  EXPECT_FALSE(verify_password("$1$saltsalt$2vnaRpHa6Jxjz5n83ok8Z0", "$1$saltsalt$2vnaRpHa6Jxjz5n83ok8Z0"));
}

TEST(PasswordHash, ConstantTimeEquality) {
  EXPECT_TRUE(equal_constant_time("", ""));
  EXPECT_TRUE(equal_constant_time("abc", "abc"));
  EXPECT_FALSE(equal_constant_time("abc", "abd"));
  EXPECT_FALSE(equal_constant_time("abc", "ab"));
  EXPECT_FALSE(equal_constant_time("ab", "abc"));
}

}  // namespace
