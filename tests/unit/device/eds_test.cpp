// CiA 306 EDS parser: the good_* fixtures parse into the expected
// description; each bad_* fixture yields an error at the exact file:line.
#include "device/eds.hpp"

#include "unit/device/source_paths.hpp"

#include <gtest/gtest.h>

#include <string>

using namespace cobridge::device;
using cobridge::device::test::fixture;

namespace {

std::string dump(const EdsResult& r) {
  std::string s;
  for (const auto& e : r.errors) s += e.to_string() + "\n";
  return s;
}

// Asserts that `name` fails with an error of `code` at `line` (and `column`
// when non-zero) whose message contains `fragment`.
void expect_error(const std::string& name, std::size_t line, EdsErrc code, const std::string& fragment,
                  std::size_t column = 0) {
  const auto path = fixture(name);
  const EdsResult r = load_eds_file(path);
  ASSERT_FALSE(r.ok()) << name << " parsed although it is broken";
  const EdsError* hit = nullptr;
  for (const auto& e : r.errors) {
    if (e.line == line && e.code == code && e.message.find(fragment) != std::string::npos) hit = &e;
  }
  ASSERT_NE(hit, nullptr) << "no error at " << name << ":" << line << " containing '" << fragment << "'; got:\n"
                          << dump(r);
  EXPECT_EQ(hit->file, path.string());
  const std::string prefix = path.string() + ":" + std::to_string(line) + ":";
  EXPECT_EQ(hit->to_string().rfind(prefix, 0), 0U) << hit->to_string();
  if (column != 0) {
    EXPECT_EQ(hit->column, column) << hit->to_string();
  }
}

}  // namespace

// CiA 306 §4.3 [FileInfo], §4.4 [DeviceInfo], §4.5 object lists.
TEST(EdsParser, GoodMinimalParsesFileAndDeviceInfo_CiA306_4_3_and_4_4) {
  const EdsResult r = load_eds_file(fixture("good_minimal.eds"));
  ASSERT_TRUE(r.ok()) << dump(r);
  const DeviceDescription& d = *r.description;
  EXPECT_EQ(d.file_info.file_name, "good_minimal.eds");
  EXPECT_EQ(d.file_info.file_version, 1);
  EXPECT_EQ(d.file_info.file_revision, 2);
  EXPECT_EQ(d.file_info.eds_version, "4.0");
  EXPECT_EQ(d.device_info.vendor_number, 0x182U);
  EXPECT_EQ(d.device_info.product_number, 0x0BE0U);
  EXPECT_EQ(d.device_info.revision_number, 0x00010003U);
  EXPECT_TRUE(d.device_info.baud_125);
  EXPECT_TRUE(d.device_info.baud_250);
  EXPECT_FALSE(d.device_info.baud_1000);
  EXPECT_TRUE(d.device_info.lss_supported);
  EXPECT_EQ(d.device_info.nr_of_tx_pdo, 1);
  EXPECT_EQ(d.device_info.nr_of_rx_pdo, 0);
  ASSERT_NE(d.object(0x1000), nullptr);
  EXPECT_EQ(d.object(0x1000)->list, ObjectList::kMandatory);
  EXPECT_EQ(d.object(0x2000)->list, ObjectList::kManufacturer);
  EXPECT_EQ(d.object(0x6010)->list, ObjectList::kOptional);
  EXPECT_EQ(d.object(0x6010)->type, ObjectType::kArray);
  EXPECT_EQ(d.object(0x1018)->type, ObjectType::kRecord);
  EXPECT_EQ(d.object(0x1018)->sub_number, 3);
  EXPECT_EQ(d.objects.size(), 7U);
}

// CiA 306 §4.6.3: ObjectType defaults to VAR; a VAR is addressed as sub 0.
TEST(EdsParser, FindAddressesVarsAsSubZeroAndRecordsBySub_CiA306_4_6) {
  const EdsResult r = load_eds_file(fixture("good_minimal.eds"));
  ASSERT_TRUE(r.ok()) << dump(r);
  const DeviceDescription& d = *r.description;
  const ObjectDesc* dev_type = d.find(0x1000, 0);
  ASSERT_NE(dev_type, nullptr);
  EXPECT_EQ(dev_type->name, "Device type");
  EXPECT_EQ(dev_type->data_type, DataType::kUnsigned32);
  EXPECT_EQ(dev_type->access, AccessType::kConst);
  EXPECT_EQ(dev_type->default_for_node(1), 0x00010196U);
  EXPECT_EQ(d.find(0x1000, 1), nullptr);
  const ObjectDesc* product = d.find(0x1018, 2);
  ASSERT_NE(product, nullptr);
  EXPECT_EQ(product->default_for_node(1), 3040U);  // decimal
  EXPECT_EQ(d.find(0x1018, 3), nullptr);
  EXPECT_EQ(d.find(0x5000, 0), nullptr);
  const ObjectDesc* node = d.find(0x2000, 0);
  ASSERT_NE(node, nullptr);
  EXPECT_EQ(node->low_limit.integer, 1U);
  EXPECT_EQ(node->high_limit.integer, 127U);
  EXPECT_FALSE(node->pdo_mapping);
  EXPECT_TRUE(d.find(0x6010, 1)->pdo_mapping);
}

// CiA 306 §4.6.3 DefaultValue "$NODEID+0x40000180": resolved per node.
TEST(EdsParser, NodeIdDefaultsResolveForEachNode_CiA306_4_6_3) {
  const EdsResult r = load_eds_file(fixture("good_minimal.eds"));
  ASSERT_TRUE(r.ok()) << dump(r);
  const ObjectDesc* cob = r.description->find(0x1800, 1);
  ASSERT_NE(cob, nullptr);
  EXPECT_TRUE(cob->default_value.plus_node_id);
  EXPECT_EQ(cob->default_value.integer, 0x40000180U);
  EXPECT_EQ(cob->default_for_node(1), 0x40000181U);
  EXPECT_EQ(cob->default_for_node(0x7F), 0x400001FFU);
  EXPECT_EQ(cob->default_for_node(32), 0x400001A0U);
  // A plain default ignores the node-ID.
  EXPECT_EQ(r.description->find(0x1800, 2)->default_for_node(5), 0xFEU);
}

// CiA 306 §4.6.3 number formats: decimal, 0x hex, leading-0 octal, negative.
TEST(EdsParser, NumberFormatsOctalAndNegative_CiA306_4_6_3) {
  const EdsResult r = load_eds_file(fixture("good_minimal.eds"));
  ASSERT_TRUE(r.ok()) << dump(r);
  EXPECT_EQ(r.description->find(0x6000, 0)->default_for_node(1), 8U);  // "010" is octal
  const ObjectDesc* preset = r.description->find(0x6010, 1);
  EXPECT_EQ(preset->data_type, DataType::kInteger32);
  EXPECT_EQ(preset->default_for_node(1), 0xFFFFFFFBU);  // bit pattern of -5 in 32 bits
  EXPECT_EQ(preset->default_signed_for_node(1), -5);
}

// CiA 306 §4.1: keys and section names are case-insensitive; CRLF, BOM,
// comments, and "0x200+$NODEID" (number first) are accepted.
TEST(EdsParser, CrlfBomMixedCaseAndInlineComments_CiA306_4_1) {
  const EdsResult r = load_eds_file(fixture("good_crlf_mixed.eds"));
  ASSERT_TRUE(r.ok()) << dump(r);
  const DeviceDescription& d = *r.description;
  EXPECT_EQ(d.file_info.file_name, "good_crlf_mixed.eds");  // no trailing '\r'
  EXPECT_EQ(d.device_info.vendor_number, 0x0069666DU);      // inline comment cut off
  EXPECT_EQ(d.device_info.product_number, 17217U);
  EXPECT_EQ(d.find(0x1000, 0)->access, AccessType::kRo);  // "RO"
  EXPECT_EQ(d.find(0x1001, 0)->data_type, DataType::kUnsigned8);  // "DataType=5"
  const ObjectDesc* map1 = d.find(0x1A00, 1);
  ASSERT_NE(map1, nullptr);
  EXPECT_EQ(map1->name, "Mapping entry 1");
  EXPECT_EQ(map1->access, AccessType::kRw);
  EXPECT_EQ(map1->default_for_node(3), 0x203U);
  EXPECT_EQ(d.find(0x1000, 0)->default_value.kind, EdsValue::Kind::kNone);
}

// CiA 301 §7.1.2 / §7.4.7.1: sizes of the static data types.
TEST(EdsParser, TypeSizesInBits_CiA301_7_4_7_1) {
  EXPECT_EQ(bit_size(DataType::kBoolean), 1U);
  EXPECT_EQ(bit_size(DataType::kInteger8), 8U);
  EXPECT_EQ(bit_size(DataType::kInteger16), 16U);
  EXPECT_EQ(bit_size(DataType::kInteger24), 24U);
  EXPECT_EQ(bit_size(DataType::kInteger32), 32U);
  EXPECT_EQ(bit_size(DataType::kInteger64), 64U);
  EXPECT_EQ(bit_size(DataType::kUnsigned8), 8U);
  EXPECT_EQ(bit_size(DataType::kUnsigned16), 16U);
  EXPECT_EQ(bit_size(DataType::kUnsigned24), 24U);
  EXPECT_EQ(bit_size(DataType::kUnsigned32), 32U);
  EXPECT_EQ(bit_size(DataType::kUnsigned64), 64U);
  EXPECT_EQ(bit_size(DataType::kReal32), 32U);
  EXPECT_EQ(bit_size(DataType::kReal64), 64U);
  EXPECT_EQ(bit_size(DataType::kTimeOfDay), 48U);
  EXPECT_EQ(bit_size(DataType::kVisibleString), 0U);
  EXPECT_EQ(bit_size(DataType::kDomain), 0U);
  EXPECT_EQ(to_string(DataType::kUnsigned32), "UNSIGNED32");
  EXPECT_EQ(to_string(AccessType::kRww), "rww");
  EXPECT_TRUE(is_signed_integer(DataType::kInteger24));
  EXPECT_FALSE(is_signed_integer(DataType::kUnsigned24));
}

// CiA 301 §7.4.7.1: 0x0099 is no data type.
TEST(EdsParserBad, WrongDataType_CiA301_7_4_7_1) {
  expect_error("bad_datatype.eds", 109, EdsErrc::kBadDataType,
               "[6000] DataType=0x0099 is not a CiA 301 data type (allowed: 0x0001..0x001B)");
}

// CiA 306 §4.5: every object named in a list needs its section.
TEST(EdsParserBad, MissingSectionNamedByObjectList_CiA306_4_5) {
  expect_error("bad_missing_section.eds", 32, EdsErrc::kMissingSection,
               "[OptionalObjects] 2=0x6000 names section [6000], which is missing");
}

// CiA 306 §4.1: a section may appear once.
TEST(EdsParserBad, DuplicateSection_CiA306_4_1) {
  expect_error("bad_duplicate_section.eds", 132, EdsErrc::kDuplicateSection,
               "duplicate section [6000] (first defined at line 107)");
}

// CiA 306 §4.6.3: DefaultValue must be decimal, 0x hex or octal.
TEST(EdsParserBad, MalformedNumberHasColumn_CiA306_4_6_3) {
  expect_error("bad_number.eds", 111, EdsErrc::kBadNumber, "[6000] DefaultValue=0x1G is not a number",
               /*column=*/14);
}

// CiA 306 §4.6.3: AccessType is one of ro, wo, rw, rwr, rww, const.
TEST(EdsParserBad, UnknownAccessType_CiA306_4_6_3) {
  expect_error("bad_access.eds", 110, EdsErrc::kBadAccessType,
               "[6000] AccessType=rx is not a CiA 306 access type (allowed: ro, wo, rw, rwr, rww, const)");
}

// CiA 306 §4.6.4: [IIIIsubS] needs its object section [IIII].
TEST(EdsParserBad, SubObjectWithoutParent_CiA306_4_6_4) {
  expect_error("bad_sub_without_parent.eds", 132, EdsErrc::kSubWithoutParent,
               "[6020sub1] has no parent object section [6020]");
}

// CiA 306 §4.1: a file cut inside a section header.
TEST(EdsParserBad, TruncatedFile_CiA306_4_1) {
  expect_error("bad_truncated.eds", 125, EdsErrc::kSyntax, "section header '[6010su' is not closed with ']'",
               /*column=*/1);
  // The cut also leaves [6010] with fewer sub-objects than SubNumber says.
  expect_error("bad_truncated.eds", 117, EdsErrc::kInconsistent, "SubNumber=2 but 1 sub-object sections");
}

// CiA 306 §4.1 (EDS is text): NUL/control bytes are reported, not parsed.
TEST(EdsParserBad, BinaryGarbage_CiA306_4_1) {
  expect_error("bad_binary.eds", 108, EdsErrc::kBinaryData, "control character 0x00", /*column=*/19);
}

// CiA 306 §4.6.3 LowLimit/HighLimit bound DefaultValue.
TEST(EdsParserBad, DefaultOutsideLimits_CiA306_4_6_3) {
  expect_error("bad_out_of_range.eds", 103, EdsErrc::kOutOfRange,
               "[2000] DefaultValue=200 is outside the limits (allowed: 1..127)");
}

// CiA 306 §4.4 vs CiA 301 §7.5.2.30: DeviceInfo and 0x1018 must agree.
TEST(EdsParserBad, IdentityDisagreesWith1018_CiA306_4_4) {
  expect_error("bad_identity.eds", 70, EdsErrc::kInconsistent,
               "[1018sub2] DefaultValue=3041 differs from [DeviceInfo] ProductNumber=0x00000BE0");
}

// CiA 301 §7.1: a value must fit its type.
TEST(EdsParserBad, ValueDoesNotFitType_CiA301_7_1) {
  const std::string text =
      "[FileInfo]\n[DeviceInfo]\nVendorNumber=1\nProductNumber=2\n"
      "[MandatoryObjects]\nSupportedObjects=2\n1=0x1000\n2=0x1001\n"
      "[1000]\nParameterName=a\nDataType=0x0007\nAccessType=ro\n"
      "[1001]\nParameterName=b\nDataType=0x0005\nAccessType=ro\nDefaultValue=300\n";
  const EdsResult r = parse_eds(text, "inline.eds");
  ASSERT_FALSE(r.ok());
  ASSERT_EQ(r.errors.size(), 1U) << dump(r);
  EXPECT_EQ(r.errors[0].line, 17U);
  EXPECT_EQ(r.errors[0].to_string(),
            "inline.eds:17:14: [1001] DefaultValue=300 does not fit UNSIGNED8 (allowed: 0..255)");
}

// CiA 306 §4.5: SupportedObjects=N needs entries 1..N, and objects need a list.
TEST(EdsParserBad, ObjectListCountsAndUnlistedObjects_CiA306_4_5) {
  const std::string text =
      "[FileInfo]\n[DeviceInfo]\nVendorNumber=1\nProductNumber=2\n"
      "[MandatoryObjects]\nSupportedObjects=3\n1=0x1000\n2=0x1001\n"
      "[1000]\nParameterName=a\nDataType=0x0007\nAccessType=ro\n"
      "[1001]\nParameterName=b\nDataType=0x0005\nAccessType=ro\n"
      "[2001]\nParameterName=c\nDataType=0x0005\nAccessType=ro\n";
  const EdsResult r = parse_eds(text, "lists.eds");
  ASSERT_FALSE(r.ok());
  bool count_error = false;
  bool unlisted = false;
  for (const auto& e : r.errors) {
    count_error |= e.line == 5 && e.message.find("SupportedObjects=3 but entry 3 is missing") != std::string::npos;
    unlisted |= e.line == 17 && e.code == EdsErrc::kUnlistedObject;
  }
  EXPECT_TRUE(count_error) << dump(r);
  EXPECT_TRUE(unlisted) << dump(r);
}

TEST(EdsParserBad, MissingFileIsAnIoErrorNotAnException) {
  const EdsResult r = load_eds_file(fixture("does_not_exist.eds"));
  ASSERT_FALSE(r.ok());
  ASSERT_EQ(r.errors.size(), 1U);
  EXPECT_EQ(r.errors[0].code, EdsErrc::kIo);
  EXPECT_EQ(std::error_code(r.errors[0].code), EdsErrc::kIo);
  EXPECT_STREQ(std::error_code(EdsErrc::kBadDataType).category().name(), "cobridge.eds");
}
