// The auth file: "user:hash" lines with crypt(3) hashes;
// a plain-text password is refused at its file:line with how to make a hash.
#include "web/auth_file.hpp"

#include "web/password_hash.hpp"
#include "web_fixture.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

using cobridge::Errc;
using cobridge::Error;
using cobridge::web::AuthFile;
using cobridge::web::test::kAliceHash;
using cobridge::web::test::kBobHash;
using ::testing::HasSubstr;
using ::testing::Not;

namespace {

class AuthFileTest : public ::testing::Test {
 protected:
  void TearDown() override { std::filesystem::remove(file_); }
  // Writes `text` as the file, mode 0600.
  void write(const std::string& text) {
    std::ofstream(file_) << text;
    ::chmod(file_.c_str(), 0600);
  }
  std::filesystem::path file_ =
      std::filesystem::temp_directory_path() / ("cobridge-auth-file-" + std::to_string(::getpid()));
};

TEST_F(AuthFileTest, HashedUsersAreCheckedWithTheirHash) {
  std::string yescrypt;
  ASSERT_FALSE(cobridge::web::hash_password("correct horse", yescrypt));
  // A CRLF line with a trailing blank: both ignored.
  write("# operators\n\nalice:" + std::string(kAliceHash) + "\nbob:" + kBobHash + " \r\ncarol:" + yescrypt + "\n");
  AuthFile auth;
  const Error loaded = auth.load(file_);
  ASSERT_FALSE(loaded) << loaded.to_string();
  EXPECT_EQ(auth.users(), 3U);
  EXPECT_TRUE(auth.check("alice", "s3cret"));
  EXPECT_TRUE(auth.check("bob", "hunter:2"));  // the first colon of the header separates
  EXPECT_TRUE(auth.check("carol", "correct horse"));
  EXPECT_FALSE(auth.check("alice", "hunter:2")) << "another user's password";
  EXPECT_FALSE(auth.check("alice", "s3cre"));
  EXPECT_FALSE(auth.check("alice", "s3cret!"));
  EXPECT_FALSE(auth.check("mallory", "s3cret")) << "an unknown user with a known password";
  EXPECT_FALSE(auth.check("", ""));
  EXPECT_FALSE(auth.check("alice", kAliceHash)) << "the hash is not the password";
}

TEST_F(AuthFileTest, APlainTextPasswordIsRefusedAtItsLine) {
  write("# operators\nalice:" + std::string(kAliceHash) + "\nbob:hunter2\n");
  AuthFile auth;
  const Error e = auth.load(file_);
  ASSERT_TRUE(e);
  EXPECT_EQ(e.kind, Errc::kInvalidArgument);
  EXPECT_EQ(e.where, file_.string() + ":3");
  EXPECT_THAT(e.message, HasSubstr("user \"bob\": plain-text password"));
  EXPECT_THAT(e.message, HasSubstr("cobridged --hash-password"));
  EXPECT_THAT(e.message, HasSubstr("mkpasswd -m yescrypt"));
  EXPECT_THAT(e.message, Not(HasSubstr("hunter2"))) << "the password is not repeated";
  EXPECT_EQ(auth.users(), 0U) << "a refused file lets nobody in";
  EXPECT_FALSE(auth.check("alice", "s3cret"));
}

TEST_F(AuthFileTest, BadLinesAreRefusedAtTheirLine) {
  const std::string alice = "alice:" + std::string(kAliceHash) + "\n";
  const struct {
    std::string text;
    std::string where;
    const char* message;
  } cases[] = {
      {alice + "bob\n", ":2", "expected user:hash"},
      {alice + ":" + kBobHash + "\n", ":2", "expected user:hash"},
      {alice + "bob:\n", ":2", "expected user:hash"},
      {"alice:$1$saltsalt$2vnaRpHa6Jxjz5n83ok8Z0\n", ":1", "legacy"},
      {alice + "# again\n" + alice, ":3", "user \"alice\" is named twice"},
      {"# nobody\n", "", "no user:hash line"},
  };
  for (const auto& c : cases) {
    write(c.text);
    AuthFile auth;
    const Error e = auth.load(file_);
    ASSERT_TRUE(e) << c.text;
    EXPECT_EQ(e.where, file_.string() + c.where) << c.text;
    EXPECT_THAT(e.message, HasSubstr(c.message)) << c.text;
  }
}

TEST_F(AuthFileTest, AFileOthersMayReadIsRefused) {
  write("alice:" + std::string(kAliceHash) + "\n");
  ::chmod(file_.c_str(), 0640);
  AuthFile auth;
  const Error e = auth.load(file_);
  ASSERT_TRUE(e);
  EXPECT_EQ(e.where, file_.string());
  EXPECT_THAT(e.message, HasSubstr("chmod 600"));
}

}  // namespace
