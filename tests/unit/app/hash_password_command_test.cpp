// `cobridged --hash-password`: the hash an operator puts
// in web.auth_file, made from a password read from standard input.
#include "app/hash_password_command.hpp"

#include "web/password_hash.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

using cobridge::app::hash_password_command;
using ::testing::HasSubstr;
using ::testing::StartsWith;

namespace {

struct Outcome {
  int status = -1;
  std::string out;
  std::string err;
};

// The command with `input` as its (non-terminal) standard input.
Outcome run(const std::string& input) {
  int fds[2];
  if (::pipe(fds) != 0) return {};
  (void)!::write(fds[1], input.data(), input.size());  // a few bytes: within the pipe's buffer
  ::close(fds[1]);
  std::FILE* in = ::fdopen(fds[0], "r");
  char* out_buf = nullptr;
  std::size_t out_size = 0;
  char* err_buf = nullptr;
  std::size_t err_size = 0;
  std::FILE* out = ::open_memstream(&out_buf, &out_size);
  std::FILE* err = ::open_memstream(&err_buf, &err_size);
  Outcome r;
  r.status = hash_password_command(in, out, err);
  std::fclose(in);
  std::fclose(out);
  std::fclose(err);
  r.out.assign(out_buf, out_size);
  r.err.assign(err_buf, err_size);
  std::free(out_buf);
  std::free(err_buf);
  return r;
}

TEST(HashPasswordCommand, PrintsAYescryptHashOfTheFirstLine) {
  const Outcome r = run("correct horse\nignored\n");
  ASSERT_EQ(r.status, 0) << r.err;
  ASSERT_THAT(r.out, StartsWith("$y$"));
  ASSERT_EQ(r.out.back(), '\n');
  const std::string hash = r.out.substr(0, r.out.size() - 1);
  EXPECT_EQ(hash.find('\n'), std::string::npos);
  EXPECT_TRUE(cobridge::web::verify_password("correct horse", hash));
  EXPECT_FALSE(cobridge::web::verify_password("correct horse\n", hash));
  EXPECT_FALSE(cobridge::web::verify_password("ignored", hash));
}

TEST(HashPasswordCommand, NoPasswordNoHash) {
  for (const char* input : {"", "\n"}) {
    const Outcome r = run(input);
    EXPECT_EQ(r.status, 2) << '"' << input << '"';
    EXPECT_EQ(r.out, "");
  }
}

}  // namespace
