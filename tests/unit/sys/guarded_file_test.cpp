// Guarded files (daemon/sys/guarded_file.hpp): a symbolic link planted where
// the gateway opens one of its files is refused, never followed (O_NOFOLLOW);
// a new file is never made over a name that exists (O_EXCL); a FIFO cannot
// hang an open; reads take at most their bound.
#include "sys/guarded_file.hpp"

#include <gtest/gtest.h>

#include <sys/stat.h>

#include "unit/support/temp_dir.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

namespace cobridge::sys {
namespace {

namespace fs = std::filesystem;

class GuardedFileTest : public ::testing::Test {
 protected:
  void SetUp() override { fs::create_directories(dir_); }
  static std::string read(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  }
  static void write(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }
  test::TempDir tmp_{"guarded-test"};
  const fs::path& dir_ = tmp_.path();
};

TEST_F(GuardedFileTest, ONoFollow_AnAppendThroughASymbolicLinkIsRefused) {
  write(dir_ / "victim", "precious\n");
  fs::create_symlink(dir_ / "victim", dir_ / "journal");
  bool created = true;
  const Result<OpenFile> f = open_for_append(dir_ / "journal", created);
  ASSERT_FALSE(f.ok());
  EXPECT_EQ(f.error().code, std::error_code(ELOOP, std::generic_category()));
  EXPECT_NE(f.error().message.find("symbolic link"), std::string::npos) << f.error().message;
  EXPECT_EQ(f.error().where, (dir_ / "journal").string());
  EXPECT_EQ(read(dir_ / "victim"), "precious\n");
}

TEST_F(GuardedFileTest, ONoFollow_AReadThroughASymbolicLinkIsRefused) {
  write(dir_ / "secret", "not yours\n");
  fs::create_symlink(dir_ / "secret", dir_ / "capture.log");
  const Result<FileText> r = read_file_bounded(dir_ / "capture.log", 1 << 20);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("symbolic link"), std::string::npos) << r.error().message;
}

TEST_F(GuardedFileTest, OExcl_ANewFileIsNeverMadeOverAnExistingNameOrALink) {
  write(dir_ / "there", "old\n");
  const Result<OpenFile> over_file = create_new_file(dir_ / "there");
  ASSERT_FALSE(over_file.ok());
  EXPECT_EQ(over_file.error().code, std::error_code(EEXIST, std::generic_category()));
  EXPECT_EQ(read(dir_ / "there"), "old\n");
  // A dangling link: following it would create the file it names.
  fs::create_symlink(dir_ / "elsewhere", dir_ / "new.log.part");
  const Result<OpenFile> over_link = create_new_file(dir_ / "new.log.part");
  ASSERT_FALSE(over_link.ok());
  EXPECT_NE(over_link.error().message.find("exists already"), std::string::npos) << over_link.error().message;
  EXPECT_FALSE(fs::exists(dir_ / "elsewhere"));
  Result<OpenFile> fresh = create_new_file(dir_ / "fresh");
  ASSERT_TRUE(fresh.ok()) << fresh.error().to_string();
  EXPECT_FALSE(write_all(*fresh, "new\n", dir_ / "fresh"));
  EXPECT_FALSE(sync_file(*fresh, dir_ / "fresh"));
  EXPECT_FALSE(sync_directory(dir_));
  EXPECT_EQ(read(dir_ / "fresh"), "new\n");
}

TEST_F(GuardedFileTest, AFifoWhereAFileShouldBeIsRefusedWithoutBlocking) {
  ASSERT_EQ(::mkfifo((dir_ / "journal").c_str(), 0600), 0);
  bool created = false;
  const Result<OpenFile> w = open_for_append(dir_ / "journal", created);
  EXPECT_FALSE(w.ok());
  const Result<FileText> r = read_file_bounded(dir_ / "journal", 1024);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("not a regular file"), std::string::npos) << r.error().message;
}

TEST_F(GuardedFileTest, AppendCreatesOnceThenAppends) {
  bool created = false;
  {
    Result<OpenFile> f = open_for_append(dir_ / "journal", created);
    ASSERT_TRUE(f.ok()) << f.error().to_string();
    EXPECT_TRUE(created);
    ASSERT_FALSE(write_all(*f, "a\n", dir_ / "journal"));
  }
  Result<OpenFile> f = open_for_append(dir_ / "journal", created);
  ASSERT_TRUE(f.ok());
  EXPECT_FALSE(created);
  ASSERT_FALSE(write_all(*f, "b\n", dir_ / "journal"));
  EXPECT_EQ(read(dir_ / "journal"), "a\nb\n");
}

TEST_F(GuardedFileTest, ReadsAreBoundedFromTheHeadOrTheTail) {
  write(dir_ / "big", "0123456789");
  const Result<FileText> head = read_file_bounded(dir_ / "big", 4, KeepEnd::head);
  ASSERT_TRUE(head.ok());
  EXPECT_EQ(head->text, "0123");
  EXPECT_EQ(head->size, 10u);
  EXPECT_EQ(head->skipped, 6u);
  const Result<FileText> tail = read_file_bounded(dir_ / "big", 4, KeepEnd::tail);
  ASSERT_TRUE(tail.ok());
  EXPECT_EQ(tail->text, "6789");
  const Result<FileText> whole = read_file_bounded(dir_ / "big", 100);
  ASSERT_TRUE(whole.ok());
  EXPECT_EQ(whole->text, "0123456789");
  EXPECT_EQ(whole->skipped, 0u);
  const Result<FileText> missing = read_file_bounded(dir_ / "none", 100);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().kind, Errc::kNotFound);
}

TEST_F(GuardedFileTest, RenameNeverReplacesWhatHasTheName) {
  write(dir_ / "a", "a\n");
  write(dir_ / "b", "b\n");
  const Error e = rename_no_replace(dir_ / "a", dir_ / "b");
  ASSERT_TRUE(e);
  EXPECT_EQ(e.code, std::error_code(EEXIST, std::generic_category()));
  EXPECT_EQ(read(dir_ / "a"), "a\n");
  EXPECT_EQ(read(dir_ / "b"), "b\n");
  ASSERT_FALSE(rename_no_replace(dir_ / "a", dir_ / "c"));
  EXPECT_FALSE(fs::exists(dir_ / "a"));
  EXPECT_EQ(read(dir_ / "c"), "a\n");
}

}  // namespace
}  // namespace cobridge::sys
