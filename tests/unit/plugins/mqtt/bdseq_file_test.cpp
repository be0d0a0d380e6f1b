// bdSeq across restarts (Sparkplug 3.0 6.4.x bdSeq,
// tck-id-payloads-nbirth-bdseq-increment: each CONNECT's bdSeq is the
// previous one + 1 mod 256), kept in a file written atomically; a damaged
// file is reported and set aside, never silently overwritten.
#include "bdseq_file.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

namespace cobridge::mqtt {
namespace {

namespace fs = std::filesystem;

class BdSeqFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() / ("cobridge-bdseq-" + std::to_string(::getpid()));
    fs::create_directories(dir);
    path = (dir / "mqtt-gw1.bdseq").string();
  }
  void TearDown() override { fs::remove_all(dir); }
  BdSeqFile make() {
    return BdSeqFile(path, [this](int, const std::string& m) { logged.push_back(m); });
  }
  std::string content() const {
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
  fs::path dir;
  std::string path;
  std::vector<std::string> logged;
};

TEST_F(BdSeqFileTest, Spec64_IncrementsAcrossRestarts) {
  {
    BdSeqFile f = make();
    f.load();
    EXPECT_EQ(f.next(), 0u);  // none yet
    EXPECT_EQ(f.next(), 1u);  // a reconnect
  }
  EXPECT_EQ(content(), "1\n");
  BdSeqFile again = make();
  again.load();
  EXPECT_EQ(again.next(), 2u);  // the restart continues, never back to 0
  EXPECT_FALSE(fs::exists(path + ".tmp"));
  EXPECT_TRUE(logged.empty());
}

TEST_F(BdSeqFileTest, Spec64_WrapsAt256) {
  std::ofstream(path) << "255\n";
  BdSeqFile f = make();
  f.load();
  EXPECT_EQ(f.next(), 0u);
}

TEST_F(BdSeqFileTest, PairContinuesFromTheOtherGateway) {
  std::ofstream(path) << "3\n";
  BdSeqFile f = make();
  f.load();
  EXPECT_EQ(f.next(41), 42u);
  EXPECT_EQ(content(), "42\n");
}

TEST_F(BdSeqFileTest, BadFileReportedAndSetAside) {
  std::ofstream(path) << "twelve\n";
  BdSeqFile f = make();
  f.load();
  ASSERT_EQ(logged.size(), 1u);
  EXPECT_NE(logged[0].find("damaged"), std::string::npos);
  EXPECT_NE(logged[0].find("twelve"), std::string::npos);
  EXPECT_TRUE(fs::exists(path + ".bad"));  // kept for the operator
  EXPECT_EQ(f.next(), 0u);
  EXPECT_EQ(content(), "0\n");
}

TEST(BdSeqParse, Values) {
  EXPECT_EQ(parse_bdseq("0\n"), std::uint8_t{0});
  EXPECT_EQ(parse_bdseq("255"), std::uint8_t{255});
  EXPECT_FALSE(parse_bdseq("256\n"));
  EXPECT_FALSE(parse_bdseq(""));
  EXPECT_FALSE(parse_bdseq("-1"));
  EXPECT_FALSE(parse_bdseq("1 2"));
}

TEST(BdSeqFileMemory, EmptyPathInMemoryOnly) {
  BdSeqFile f("", [](int, const std::string&) {});
  f.load();
  EXPECT_EQ(f.next(), 0u);
  EXPECT_EQ(f.next(), 1u);
}

}  // namespace
}  // namespace cobridge::mqtt
