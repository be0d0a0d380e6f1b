// DescriptionChoice: the description (EDS) and family profile a device is
// configured and decoded with, from the shipped descriptions: by identity
// (CiA 301 §7.5.2.35, 0x1018) and the configured channel variant (J§1.2),
// the configured EDS first; the standby's from the configured model when it
// heard no identity (ifm's product code is not checkable, F§7.3).
#include "bus/description_choice.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "unit/device/source_paths.hpp"

namespace cobridge::bus {
namespace {

constexpr std::uint32_t kNovotechnik = 0x182;
constexpr std::uint32_t kRsa3200 = 0xBF3;

class DescriptionChoiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    for (const auto& e : catalog.load_directory(device::test::shipped_devices_dir())) ADD_FAILURE() << e.to_string();
  }
  static std::string file_of(const Result<DescriptionChoice>& r) {
    return r.ok() ? std::filesystem::path(r->description->source).filename().string() : r.error().to_string();
  }
  device::DeviceCatalog catalog;
};

canopen::LssAddress identity(std::uint32_t vendor, std::uint32_t product) {
  canopen::LssAddress id{};
  id.vendor = vendor;
  id.product = product;
  id.serial = 2500;
  return id;
}

TEST_F(DescriptionChoiceTest, J1_2_TheConfiguredChannelVariantChoosesBetweenTheTwoDescriptions) {
  config::Device cfg;
  cfg.channels = 2;
  EXPECT_EQ(file_of(choose_description(catalog, cfg, identity(kNovotechnik, kRsa3200))), "novotechnik-rsa3200-2ch.eds");
  cfg.channels = 1;
  EXPECT_EQ(file_of(choose_description(catalog, cfg, identity(kNovotechnik, kRsa3200))), "novotechnik-rsa3200-1ch.eds");
  cfg.channels.reset();  // no variant: a candidate, whose plan probes the channels
  const auto any = choose_description(catalog, cfg, identity(kNovotechnik, kRsa3200));
  ASSERT_TRUE(any.ok()) << any.error().to_string();
  EXPECT_EQ(std::string(any->profile.manual), "J");
}

TEST_F(DescriptionChoiceTest, TheConfiguredEdsFileWinsOverTheIdentitysSelection) {
  config::Device cfg;
  cfg.channels = 2;
  cfg.eds = device::test::shipped_devices_dir() / "novotechnik-rsa3200-1ch.eds";
  EXPECT_EQ(file_of(choose_description(catalog, cfg, identity(kNovotechnik, kRsa3200))), "novotechnik-rsa3200-1ch.eds");
}

TEST_F(DescriptionChoiceTest, NoDescriptionIsNotFoundAndNamesTheIdentity) {
  const auto r = choose_description(catalog, config::Device{}, identity(0x1234, 0x5678));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().kind, Errc::kNotFound);
  EXPECT_EQ(r.error().message, "no device description for vendor 0x1234 product 0x5678 revision 0x0");
}

TEST_F(DescriptionChoiceTest, ADescriptionOfNoKnownFamilyIsUnsupported) {
  // The parser's minimal fixture under a vendor of no family cobridge knows.
  std::ifstream in(device::test::fixture("good_minimal.eds"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string vendor = "0x00000182";  // [DeviceInfo] VendorNumber and 0x1018/1's default
  ASSERT_NE(text.find(vendor), std::string::npos);
  for (auto at = text.find(vendor); at != std::string::npos; at = text.find(vendor, at)) {
    text.replace(at, vendor.size(), "0x00001234");
  }
  const auto path = std::filesystem::path(::testing::TempDir()) / "no_family.eds";
  std::ofstream(path) << text;
  for (const auto& e : catalog.load_file(path)) ADD_FAILURE() << e.to_string();
  canopen::LssAddress id = identity(0x1234, 0x0BE0);
  id.revision = 0x00010003;
  const auto r = choose_description(catalog, config::Device{}, id);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().kind, Errc::kUnsupported);
  EXPECT_NE(r.error().message.find("names no known family"), std::string::npos) << r.error().message;
}

TEST_F(DescriptionChoiceTest, F7_3_TheStandbyFindsAnIfmModelByItsFamilyWithoutAProductCode) {
  config::Device cfg;
  cfg.model = "RM8";
  const auto r = description_from_config(catalog, cfg, canopen::LssAddress{});
  EXPECT_EQ(file_of(r), "ifm-rm8-rm9.eds");
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(std::string(r->profile.manual), "F");
}

TEST_F(DescriptionChoiceTest, TheStandbyPrefersTheIdentityTheMasterReadOverTheModel) {
  config::Device cfg;
  cfg.model = "RM8";  // configured so, but the master read a rotary's identity there
  const auto r = description_from_config(catalog, cfg, identity(kNovotechnik, kRsa3200));
  ASSERT_TRUE(r.ok()) << r.error().to_string();
  EXPECT_EQ(std::string(r->profile.manual), "J");
  cfg.model = "RSA-3200";  // no identity heard: the model's product code
  EXPECT_NE(file_of(description_from_config(catalog, cfg, canopen::LssAddress{})).find("rsa3200"), std::string::npos);
  const auto none = description_from_config(catalog, config::Device{}, canopen::LssAddress{});
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().kind, Errc::kNotFound);
}

}  // namespace
}  // namespace cobridge::bus
