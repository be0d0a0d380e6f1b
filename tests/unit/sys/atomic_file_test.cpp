// The gateway's own files are replaced whole or not at all, and appended to
// in one write.
#include "sys/atomic_file.hpp"

#include <gtest/gtest.h>

#include "unit/support/temp_dir.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

namespace cobridge::sys {
namespace {

namespace fs = std::filesystem;

class AtomicFileTest : public ::testing::Test {
 protected:
  static std::string read(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  }
  test::TempDir tmp_{"atomic-test"};
  const fs::path& dir_ = tmp_.path();
};

TEST_F(AtomicFileTest, ReplacesTheFileAndLeavesNoTemporaryFile) {
  const auto path = dir_ / "sub" / "state";
  ASSERT_FALSE(write_file_atomically(path, "one\n"));  // creates the directories
  ASSERT_FALSE(write_file_atomically(path, "two\n"));
  EXPECT_EQ(read(path), "two\n");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_ / "sub"), fs::directory_iterator{}), 1);
}

TEST_F(AtomicFileTest, AppendsAndCreates) {
  const auto path = dir_ / "journal";
  ASSERT_FALSE(append_to_file(path, "a\n"));
  ASSERT_FALSE(append_to_file(path, "b\n", true));  // synced: the same text
  EXPECT_EQ(read(path), "a\nb\n");
}

TEST_F(AtomicFileTest, AFailureNamesTheFileAndLeavesItAsItWas) {
  fs::create_directories(dir_);
  std::ofstream(dir_ / "blocker") << "x";  // a file where a directory should be
  const Error e = write_file_atomically(dir_ / "blocker" / "state", "text");
  ASSERT_TRUE(e);
  EXPECT_EQ(e.kind, Errc::kFailed);
  EXPECT_EQ(e.where, (dir_ / "blocker" / "state").string());
  EXPECT_NE(e.message.find("cannot create the directory"), std::string::npos) << e.message;
  const Error a = append_to_file(dir_ / "blocker" / "journal", "text");
  ASSERT_TRUE(a);
  EXPECT_EQ(read(dir_ / "blocker"), "x");
}

// A journal's name made a symbolic link to another file: appending refuses
// it (O_NOFOLLOW) and the file it names is untouched; a replacement replaces
// the link itself, never the file it names.
TEST_F(AtomicFileTest, ASymbolicLinkIsNeverWrittenThrough) {
  fs::create_directories(dir_);
  std::ofstream(dir_ / "victim") << "precious\n";
  fs::create_symlink(dir_ / "victim", dir_ / "journal");
  const Error a = append_to_file(dir_ / "journal", "event\n");
  ASSERT_TRUE(a);
  EXPECT_NE(a.message.find("symbolic link"), std::string::npos) << a.message;
  EXPECT_EQ(read(dir_ / "victim"), "precious\n");
  ASSERT_FALSE(write_file_atomically(dir_ / "journal", "whole\n"));
  EXPECT_FALSE(fs::is_symlink(dir_ / "journal"));
  EXPECT_EQ(read(dir_ / "journal"), "whole\n");
  EXPECT_EQ(read(dir_ / "victim"), "precious\n");
}

}  // namespace
}  // namespace cobridge::sys
