// app/validation: the check that --check-config, the start and every SIGHUP
// reload run on the configuration file. A file with a dotted key or table
// header 100 000 levels deep is an error with file:line:col and the limit,
// and no configuration, never a crash in the TOML parser (a reload must not
// kill the running daemon).
#include "app/validation.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace {

namespace fs = std::filesystem;
using cobridge::app::validate;

std::string dotted(std::size_t segments) {
  std::string s = "a";
  for (std::size_t i = 1; i < segments; ++i) s += ".a";
  return s;
}

class Validation : public ::testing::Test {
 protected:
  void TearDown() override { fs::remove(file_); }
  const fs::path& write(const std::string& text) {
    std::ofstream(file_) << text;
    return file_;
  }
  fs::path file_ = fs::temp_directory_path() / ("cobridge-validation-" + std::to_string(::getpid()) + ".toml");
};

TEST_F(Validation, AKeyOrHeader100000LevelsDeepIsAnErrorWithItsPlaceNotACrash) {
  const std::string deep = dotted(100000);
  for (const std::string& form : {deep + " = 1", "[" + deep + "]", "[[" + deep + "]]", "x = { " + deep + " = 1 }"}) {
    const auto v = validate(write("[gateway]\nid = \"gw\"\n\n" + form + "\n"));
    EXPECT_FALSE(v.config.has_value()) << form.substr(0, 20);
    ASSERT_EQ(v.errors.size(), 1u) << form.substr(0, 20);
    const std::string e = v.errors.front().to_string();
    EXPECT_EQ(e.rfind(file_.string() + ":4:", 0), 0u) << e;
    EXPECT_NE(e.find("nested more than 32 levels deep"), std::string::npos) << e;
  }
}

TEST_F(Validation, AKeyAtTheLimitIsOnlyAnUnknownKey) {
  const auto v = validate(write(dotted(32) + " = 1\n"));
  ASSERT_EQ(v.errors.size(), 1u);
  EXPECT_NE(v.errors.front().to_string().find("unknown key"), std::string::npos) << v.errors.front().to_string();
}

}  // namespace
