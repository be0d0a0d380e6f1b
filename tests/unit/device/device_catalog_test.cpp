// DeviceCatalog: loading directories of EDS files, error reporting with
// file and line, duplicate identities, and selection by identity
// (CiA 301 §7.5.2.30 identity object 0x1018: vendor, product, revision).
#include "device/device_catalog.hpp"

#include "unit/device/source_paths.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

using namespace cobridge::device;
using cobridge::device::test::fixture;
namespace fs = std::filesystem;

namespace {

// A scratch directory removed at the end of the test.
class TempDir {
 public:
  explicit TempDir(const std::string& tag)
      : path_(fs::temp_directory_path() / ("cobridge-eds-" + tag + "-" + std::to_string(::getpid()))) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

std::string dump(const std::vector<EdsError>& errors) {
  std::string s;
  for (const auto& e : errors) s += e.to_string() + "\n";
  return s;
}

DeviceDescription description(std::uint32_t vendor, std::uint32_t product, std::uint32_t revision,
                              std::string variant = {}, std::string source = "mem.eds") {
  DeviceDescription d;
  d.source = std::move(source);
  d.device_info.vendor_number = vendor;
  d.device_info.product_number = product;
  d.device_info.revision_number = revision;
  d.selection.variant = std::move(variant);
  return d;
}

}  // namespace

TEST(DeviceCatalog, LoadsEveryEdsFileOfADirectory) {
  TempDir dir("load");
  fs::copy_file(fixture("good_minimal.eds"), dir.path() / "a.eds");
  fs::copy_file(fixture("good_crlf_mixed.eds"), dir.path() / "B.EDS");  // extension in any case
  std::ofstream(dir.path() / "notes.txt") << "not an EDS\n";
  DeviceCatalog catalog;
  const auto errors = catalog.load_directory(dir.path());
  EXPECT_TRUE(errors.empty()) << dump(errors);
  EXPECT_EQ(catalog.size(), 2U);
  EXPECT_NE(catalog.select(0x182, 0x0BE0), nullptr);
  EXPECT_NE(catalog.select(0x0069666D, 17217), nullptr);
}

// Errors of broken files name file and line; good files still load.
TEST(DeviceCatalog, ReportsParseErrorsWithFileAndLineAndKeepsGoodFiles) {
  TempDir dir("errors");
  fs::copy_file(fixture("good_minimal.eds"), dir.path() / "good.eds");
  fs::copy_file(fixture("bad_datatype.eds"), dir.path() / "rotary.eds");
  DeviceCatalog catalog;
  const auto errors = catalog.load_directory(dir.path());
  ASSERT_EQ(errors.size(), 1U) << dump(errors);
  EXPECT_EQ(errors[0].to_string(), (dir.path() / "rotary.eds").string() +
                                       ":109: [6000] DataType=0x0099 is not a CiA 301 data type "
                                       "(allowed: 0x0001..0x001B)");
  EXPECT_EQ(catalog.errors().size(), 1U);
  EXPECT_EQ(catalog.size(), 1U);
}

TEST(DeviceCatalog, DuplicateIdentityIsAnErrorNamingBothFiles) {
  TempDir dir("dup");
  fs::copy_file(fixture("good_minimal.eds"), dir.path() / "first.eds");
  fs::copy_file(fixture("good_minimal.eds"), dir.path() / "second.eds");
  DeviceCatalog catalog;
  const auto errors = catalog.load_directory(dir.path());
  ASSERT_EQ(errors.size(), 1U) << dump(errors);
  EXPECT_EQ(errors[0].code, EdsErrc::kDuplicateIdentity);
  EXPECT_NE(errors[0].message.find((dir.path() / "first.eds").string()), std::string::npos) << errors[0].message;
  EXPECT_NE(errors[0].message.find((dir.path() / "second.eds").string()), std::string::npos) << errors[0].message;
  EXPECT_EQ(errors[0].file, (dir.path() / "second.eds").string());
  EXPECT_EQ(catalog.size(), 1U);
}

// A user directory adds devices on top of the shipped ones; the same
// identity in both is a duplicate.
TEST(DeviceCatalog, ExtraUserDirectoriesAddToTheCatalog) {
  TempDir shipped("shipped");
  TempDir user("user");
  fs::copy_file(fixture("good_minimal.eds"), shipped.path() / "rotary.eds");
  fs::copy_file(fixture("good_crlf_mixed.eds"), user.path() / "ifm.eds");
  fs::copy_file(fixture("good_minimal.eds"), user.path() / "rotary-copy.eds");
  DeviceCatalog catalog;
  EXPECT_TRUE(catalog.load_directory(shipped.path()).empty());
  const auto errors = catalog.load_directory(user.path());
  ASSERT_EQ(errors.size(), 1U) << dump(errors);
  EXPECT_EQ(errors[0].code, EdsErrc::kDuplicateIdentity);
  EXPECT_EQ(catalog.size(), 2U);
}

TEST(DeviceCatalog, MissingDirectoryIsReported) {
  DeviceCatalog catalog;
  const auto errors = catalog.load_directory("/nonexistent/cobridge/devices");
  ASSERT_EQ(errors.size(), 1U);
  EXPECT_EQ(errors[0].code, EdsErrc::kIo);
  EXPECT_NE(errors[0].to_string().find("/nonexistent/cobridge/devices"), std::string::npos);
}

// CiA 301 §7.5.2.30 revision number: the newest description not newer than
// the device wins.
TEST(DeviceCatalog, RevisionPicksNewestNotNewerThanDevice_CiA301_7_5_2_30) {
  DeviceCatalog catalog;
  EXPECT_TRUE(catalog.add(description(0x182, 0x0BB8, 0x00010000, {}, "v1.eds")).empty());
  EXPECT_TRUE(catalog.add(description(0x182, 0x0BB8, 0x00020000, {}, "v2.eds")).empty());
  EXPECT_EQ(catalog.select(0x182, 0x0BB8, 0x00010005)->source, "v1.eds");
  EXPECT_EQ(catalog.select(0x182, 0x0BB8, 0x00020000)->source, "v2.eds");
  EXPECT_EQ(catalog.select(0x182, 0x0BB8, 0x00030001)->source, "v2.eds");
  EXPECT_EQ(catalog.select(0x182, 0x0BB8)->source, "v2.eds");
  EXPECT_EQ(catalog.select(0x182, 0x0BB8, 0x0000FFFF), nullptr);
}

TEST(DeviceCatalog, VariantsOfOneProductAreNotDuplicates) {
  DeviceCatalog catalog;
  EXPECT_TRUE(catalog.add(description(0x182, 0x0BE0, 0, "1ch", "1ch.eds")).empty());
  EXPECT_TRUE(catalog.add(description(0x182, 0x0BE0, 0, "2ch", "2ch.eds")).empty());
  EXPECT_EQ(catalog.select(0x182, 0x0BE0, std::nullopt, "2CH")->source, "2ch.eds");  // case-insensitive
  EXPECT_EQ(catalog.select(0x182, 0x0BE0), nullptr);                                 // ambiguous
  EXPECT_EQ(catalog.candidates(0x182, 0x0BE0).size(), 2U);
  // Another 2ch file with the same identity is a duplicate.
  const auto errors = catalog.add(description(0x182, 0x0BE0, 0, "2ch", "again.eds"));
  ASSERT_EQ(errors.size(), 1U);
  EXPECT_NE(errors[0].message.find("2ch.eds"), std::string::npos);
  EXPECT_NE(errors[0].message.find("again.eds"), std::string::npos);
}

TEST(DeviceCatalog, AdditionalProductsAndMatchAnyProduct) {
  DeviceCatalog catalog;
  DeviceDescription multi = description(0x182, 0x0BB8, 0, {}, "multi.eds");
  multi.selection.additional_products = {0x0BD5};
  EXPECT_TRUE(catalog.add(std::move(multi)).empty());
  DeviceDescription any = description(0x69666D, 0x4341, 0, {}, "any.eds");
  any.selection.match_any_product = true;
  EXPECT_TRUE(catalog.add(std::move(any)).empty());
  EXPECT_TRUE(catalog.add(description(0x69666D, 0x7777, 0, {}, "exact.eds")).empty());
  EXPECT_EQ(catalog.select(0x182, 0x0BD5)->source, "multi.eds");
  EXPECT_EQ(catalog.select(0x69666D, 0x1111)->source, "any.eds");
  EXPECT_EQ(catalog.select(0x69666D, 0x7777)->source, "exact.eds");  // an exact match wins
  // A legacy code claimed by a second file clashes with the first.
  EXPECT_EQ(catalog.add(description(0x182, 0x0BD5, 0, {}, "mz1.eds")).size(), 1U);
}
