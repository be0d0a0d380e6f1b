// check_eds (daemon/device/eds_check): every shipped EDS passes it (what
// third-party masters import from us must be right), and each rule finds the
// defect it names. Rules: CiA 306 §4.4 (PDO counts), §4.5 (object lists),
// §4.6.3 (SubNumber), CiA 301 §7.4.3 (sub-index 0, ARRAY types), §7.4.8.1
// (mapping entries), the family's manual (objects it names).
#include "device/eds_check.hpp"

#include "device/device_catalog.hpp"
#include "device/eds.hpp"
#include "families/family.hpp"

#include "unit/device/source_paths.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

using namespace cobridge::device;
using cobridge::device::test::fixture;
using cobridge::device::test::shipped_devices_dir;
namespace families = cobridge::families;

namespace {

std::string dump(const std::vector<cobridge::Error>& errors) {
  std::string s;
  for (const auto& e : errors) s += e.to_string() + "\n";
  return s;
}

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

DeviceDescription parsed(const std::string& text) {
  EdsResult r = parse_eds(text, "check.eds");
  EXPECT_TRUE(r.ok()) << (r.errors.empty() ? "" : r.errors.front().to_string());
  return r.ok() ? std::move(*r.description) : DeviceDescription{};
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// The findings of the good fixture changed in one place.
std::vector<cobridge::Error> check_changed(const std::string& from, const std::string& to) {
  return check_eds(parsed(replaced(read_text(fixture("good_pdo_mapping.eds")), from, to)));
}

bool mentions(const std::vector<cobridge::Error>& errors, const std::string& where, const std::string& text) {
  for (const auto& e : errors) {
    if (e.where.find(where) != std::string::npos && e.message.find(text) != std::string::npos) return true;
  }
  return false;
}

}  // namespace

TEST(EdsCheck, EveryShippedEdsPassesEveryRule) {
  std::size_t files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(shipped_devices_dir())) {
    if (entry.path().extension() != ".eds") continue;
    ++files;
    EdsResult r = load_eds_file(entry.path());
    ASSERT_TRUE(r.ok()) << entry.path();
    const auto findings = check_eds(*r.description);
    EXPECT_TRUE(findings.empty()) << entry.path() << ":\n" << dump(findings);
    EXPECT_NE(families::find_family(r.description->selection.family), nullptr)
        << entry.path() << " names no known family";
  }
  EXPECT_EQ(files, 12U);
}

// E§4.1 0x1A00/1 = 0x60200120 names 0x6020/1; the shipped file
// must define it (INTEGER32, readable, mappable) so an importing master
// decodes the TPDO.
TEST(EdsCheck, MultiturnDefinesThe0x6020ItsDefaultMappingNames) {
  EdsResult r = load_eds_file(shipped_devices_dir() / "novotechnik-multiturn.eds");
  ASSERT_TRUE(r.ok());
  const ObjectDesc* entry = r.description->find(0x1A00, 1);
  ASSERT_NE(entry, nullptr);
  EXPECT_EQ(entry->default_for_node(1), 0x60200120U);
  const ObjectDesc* position = r.description->find(0x6020, 1);
  ASSERT_NE(position, nullptr);
  EXPECT_EQ(position->data_type, DataType::kInteger32);
  EXPECT_EQ(position->access, AccessType::kRo);
  EXPECT_TRUE(position->pdo_mapping);
}

TEST(EdsCheck, GoodFixtureHasNoFinding) {
  EdsResult r = load_eds_file(fixture("good_pdo_mapping.eds"));
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(check_eds(*r.description).empty()) << dump(check_eds(*r.description));
}

// CiA 301 §7.4.8.1: a mapping entry names an object the file defines.
TEST(EdsCheck, MappingOfAnUndefinedObjectIsFound) {
  EdsResult r = load_eds_file(fixture("bad_pdo_mapping_undefined.eds"));
  ASSERT_TRUE(r.ok());
  const auto findings = check_eds(*r.description);
  ASSERT_EQ(findings.size(), 1U) << dump(findings);
  EXPECT_EQ(findings[0].kind, cobridge::Errc::kInvalidArgument);
  EXPECT_EQ(findings[0].code, make_error_code(EdsErrc::kMissingSection));
  EXPECT_NE(findings[0].where.find("[1A00sub1]"), std::string::npos);
  EXPECT_NE(findings[0].message.find("0x6020/1"), std::string::npos);
}

TEST(EdsCheck, MappingOfAnObjectWithPdoMappingZeroIsFound) {
  const auto f = check_changed("DefaultValue=-5\nPDOMapping=1", "DefaultValue=-5\nPDOMapping=0");
  EXPECT_TRUE(mentions(f, "[1A00sub1]", "PDOMapping=0")) << dump(f);
}

TEST(EdsCheck, MappingWithTheWrongBitLengthIsFound) {
  const auto f = check_changed("DefaultValue=0x60100120", "DefaultValue=0x60100110");
  EXPECT_TRUE(mentions(f, "[1A00sub1]", "16 bits")) << dump(f);
}

TEST(EdsCheck, TpdoMappingOfAWriteOnlyObjectIsFound) {
  const auto f = check_changed("DataType=0x0004\nAccessType=rw", "DataType=0x0004\nAccessType=wo");
  EXPECT_TRUE(mentions(f, "[1A00sub1]", "TPDO cannot read")) << dump(f);
}

TEST(EdsCheck, MoreThan64BitsInOnePdoIsFound) {
  std::string text = read_text(fixture("good_pdo_mapping.eds"));
  text = replaced(text, "SubNumber=2\n\n[1A00sub0]", "SubNumber=4\n\n[1A00sub0]");
  text = replaced(text, "Number of mapped objects\nDataType=0x0005\nAccessType=rw\nDefaultValue=1",
                  "Number of mapped objects\nDataType=0x0005\nAccessType=rw\nDefaultValue=3");
  const std::string slot = "\n[1A00subN]\nParameterName=Mapping entry N\nDataType=0x0007\nAccessType=rw\n"
                           "DefaultValue=0x60100120\n";
  std::string extra = replaced(replaced(slot, "subN", "sub2"), "entry N", "entry 2") +
                      replaced(replaced(slot, "subN", "sub3"), "entry N", "entry 3");
  text = replaced(text, "\n[2000]", extra + "\n[2000]");
  const auto f = check_eds(parsed(text));
  EXPECT_TRUE(mentions(f, "[1A00]", "96 bits mapped")) << dump(f);
}

// CiA 306 §4.4: NrOfTXPDO counts the TPDOs the file defines.
TEST(EdsCheck, WrongNrOfTxPdoIsFound) {
  const auto f = check_changed("NrOfTXPDO=1", "NrOfTXPDO=2");
  EXPECT_TRUE(mentions(f, "[DeviceInfo]", "NrOfTXPDO=2")) << dump(f);
}

// CiA 306 §4.5: the identity 0x1018 is a mandatory object and sits in
// [MandatoryObjects] (the parser already refuses 0x1000/0x1001 elsewhere and
// manufacturer objects outside [ManufacturerObjects]).
TEST(EdsCheck, MandatoryObjectInTheOptionalListIsFound) {
  std::string text = read_text(fixture("good_pdo_mapping.eds"));
  text = replaced(text, "[MandatoryObjects]\nSupportedObjects=3\n1=0x1000\n2=0x1001\n3=0x1018\n",
                  "[MandatoryObjects]\nSupportedObjects=2\n1=0x1000\n2=0x1001\n");
  text = replaced(text, "[OptionalObjects]\nSupportedObjects=4\n", "[OptionalObjects]\nSupportedObjects=5\n");
  text = replaced(text, "4=0x6010\n", "4=0x6010\n5=0x1018\n");
  const auto f = check_eds(parsed(text));
  EXPECT_TRUE(mentions(f, "[1018]", "MandatoryObjects")) << dump(f);
}

// CiA 301 §7.4.3: sub-index 0 holds the highest sub-index supported.
TEST(EdsCheck, SubIndexZeroThatDisagreesWithTheEntriesIsFound) {
  const auto f = check_changed("Number of channels\nDataType=0x0005\nAccessType=ro\nDefaultValue=1",
                               "Number of channels\nDataType=0x0005\nAccessType=ro\nDefaultValue=2");
  EXPECT_TRUE(mentions(f, "[6010sub0]", "highest sub-index defined is 1")) << dump(f);
}

// The family's manual names objects its EDS must define (families).
TEST(EdsCheck, ObjectTheFamilyManualNamesButTheFileLacksIsFound) {
  const auto f = check_changed("[DeviceInfo]", "[Cobridge]\nFamily=novotechnik-rotary\n\n[DeviceInfo]");
  EXPECT_TRUE(mentions(f, "[6020]", "manual J")) << dump(f);
  EXPECT_TRUE(mentions(f, "[1017]", "manual J")) << dump(f);
}

// The shipped files carry the identity their family module defines
// (vendor, product codes, family name), so that one place holds each fact.
TEST(EdsCheck, EveryShippedEdsCarriesItsFamilysIdentity) {
  for (const auto& entry : std::filesystem::directory_iterator(shipped_devices_dir())) {
    if (entry.path().extension() != ".eds") continue;
    EdsResult r = load_eds_file(entry.path());
    ASSERT_TRUE(r.ok()) << entry.path();
    const DeviceDescription& d = *r.description;
    const families::Family* f = families::find_family(d.selection.family);
    ASSERT_NE(f, nullptr) << entry.path();
    EXPECT_EQ(d.device_info.vendor_number, f->vendor) << entry.path();
    EXPECT_EQ(families::family_of(d.device_info.vendor_number, d.device_info.product_number), f) << entry.path();
    for (const std::uint32_t p : d.selection.additional_products) EXPECT_TRUE(f->lists_product(p)) << entry.path();
    EXPECT_EQ(d.selection.match_any_product, f->match_any_product) << entry.path();
  }
}

TEST(EdsError, BecomesTheProjectsErrorShape) {
  const EdsError e{"x.eds", 12, 3, EdsErrc::kBadDataType, "[6000] DataType=0x99 is not a CiA 301 data type"};
  const cobridge::Error error = to_error(e);
  EXPECT_EQ(error.kind, cobridge::Errc::kInvalidArgument);
  EXPECT_EQ(error.code, make_error_code(EdsErrc::kBadDataType));
  EXPECT_EQ(error.where, "x.eds:12:3");
  EXPECT_EQ(error.to_string(), e.to_string());
  EXPECT_EQ(to_error(EdsError{"y.eds", 0, 0, EdsErrc::kIo, "cannot open the file"}).kind, cobridge::Errc::kNotFound);
}

// The catalog runs the same check over what it loaded (for the daemon's and
// the CLI's use): the shipped directory has no finding, a bad file has one.
TEST(EdsCheck, CatalogChecksEveryLoadedDescription) {
  DeviceCatalog shipped;
  ASSERT_TRUE(shipped.load_directory(shipped_devices_dir()).empty());
  EXPECT_TRUE(shipped.check().empty()) << dump(shipped.check());
  DeviceCatalog bad;
  ASSERT_TRUE(bad.load_file(fixture("bad_pdo_mapping_undefined.eds")).empty());
  EXPECT_EQ(bad.check().size(), 1U);
}
