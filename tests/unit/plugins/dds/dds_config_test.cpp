// DdsConfig parsing (docs/dds.md "Configuration"; no CiA clause applies):
// defaults, every key, and each kind of refusal with its code and a message
// naming the key.
#include "dds/dds_config.hpp"

#include <gtest/gtest.h>

using namespace cobridge::dds;

namespace {

// docs/dds.md "Configuration": an empty table gives the documented defaults.
TEST(DdsConfig, DocsDds_EmptyGivesDefaults) {
  const DdsConfigResult r = parse_dds_config("");
  ASSERT_TRUE(r.ok()) << r.error.message;
  EXPECT_EQ(r.config.domain, 0u);
  EXPECT_EQ(r.config.sample_reliability, Reliability::kBestEffort);
  EXPECT_EQ(r.config.sample_depth, 1);
  EXPECT_EQ(r.config.topic_prefix, "");
  EXPECT_TRUE(r.config.write_batch);
  EXPECT_EQ(r.config.liveliness_lease_ms, 500);
  EXPECT_EQ(r.config.sample_path, SamplePath::kAuto);
  EXPECT_TRUE(r.config.samples_on_dispatcher()) << "the dispatcher writes samples by default";
  EXPECT_TRUE(r.config.spill_to_writer_thread()) << "and spills a full reliable history to the writer thread";
  EXPECT_FALSE(r.config.security.has_value()) << "DDS Security is off without [outputs.dds.security]";
}

// docs/dds.md "Configuration", sample_path: "auto" writes on the dispatcher and
// spills, whatever the reliability; "dispatcher" never spills; "writer-thread"
// never writes on the dispatcher.
TEST(DdsConfig, DocsDds_SamplePath) {
  const DdsConfig reliable = parse_dds_config("sample_reliability = \"reliable\"").config;
  EXPECT_TRUE(reliable.samples_on_dispatcher());
  EXPECT_TRUE(reliable.spill_to_writer_thread());
  EXPECT_FALSE(parse_dds_config("sample_path = \"writer-thread\"").config.samples_on_dispatcher());
  EXPECT_FALSE(parse_dds_config("sample_path = \"writer-thread\"").config.spill_to_writer_thread());
  const DdsConfigResult d = parse_dds_config("sample_path = \"dispatcher\"\nsample_reliability = \"reliable\"");
  ASSERT_TRUE(d.ok()) << d.error.message;
  EXPECT_TRUE(d.config.samples_on_dispatcher());
  EXPECT_FALSE(d.config.spill_to_writer_thread());
}

// docs/dds.md "Configuration": every key read.
TEST(DdsConfig, DocsDds_AllKeys) {
  const DdsConfigResult r =
      parse_dds_config("domain = 42\nsample_reliability = \"reliable\"\nsample_depth = 16\ntopic_prefix = \"p/\"\n"
                       "write_batch = false\nliveliness_lease_ms = 250\npartition = \"hall-3\"\n");
  ASSERT_TRUE(r.ok()) << r.error.message;
  EXPECT_EQ(r.config.domain, 42u);
  EXPECT_EQ(r.config.sample_reliability, Reliability::kReliable);
  EXPECT_EQ(r.config.sample_depth, 16);
  EXPECT_EQ(r.config.topic_prefix, "p/");
  EXPECT_FALSE(r.config.write_batch);
  EXPECT_EQ(r.config.liveliness_lease_ms, 250);
  EXPECT_EQ(r.config.partition, "hall-3");
}

// docs/dds.md "Configuration": refusals carry a code and name the key.
TEST(DdsConfig, DocsDds_Refusals) {
  struct Case {
    const char* text;
    DdsConfigErrc code;
    const char* mentions;
  };
  const Case cases[] = {
      {"domain = ", DdsConfigErrc::kSyntax, "line 1"},
      {"reliability = \"reliable\"", DdsConfigErrc::kUnknownKey, "'reliability'"},
      {"domain = \"0\"", DdsConfigErrc::kWrongType, "'domain'"},
      {"domain = 233", DdsConfigErrc::kOutOfRange, "'domain'"},
      {"domain = -1", DdsConfigErrc::kOutOfRange, "'domain'"},
      {"sample_reliability = \"best_effort\"", DdsConfigErrc::kOutOfRange, "best_effort"},
      {"sample_reliability = true", DdsConfigErrc::kWrongType, "'sample_reliability'"},
      {"sample_depth = 0", DdsConfigErrc::kOutOfRange, "'sample_depth'"},
      {"sample_depth = 1.5", DdsConfigErrc::kWrongType, "'sample_depth'"},
      {"topic_prefix = 3", DdsConfigErrc::kWrongType, "'topic_prefix'"},
      {"write_batch = \"yes\"", DdsConfigErrc::kWrongType, "'write_batch' must be true or false"},
      {"write_batch = 1", DdsConfigErrc::kWrongType, "'write_batch'"},
      {"writebatch = true", DdsConfigErrc::kUnknownKey, "write_batch"},
      {"partition = 3", DdsConfigErrc::kWrongType, "'partition'"},
      {"sample_path = \"inline\"", DdsConfigErrc::kOutOfRange, "'sample_path' must be"},
      {"liveliness_lease_ms = 99", DdsConfigErrc::kOutOfRange, "'liveliness_lease_ms' must be 100..3600000"},
      {"liveliness_lease_ms = 3600001", DdsConfigErrc::kOutOfRange, "'liveliness_lease_ms'"},
      {"liveliness_lease_ms = \"1s\"", DdsConfigErrc::kWrongType, "'liveliness_lease_ms'"},
      {"security = \"on\"", DdsConfigErrc::kWrongType, "'security' must be a table"},
      {"[security]\nidentity_ca = 3", DdsConfigErrc::kWrongType, "'security.identity_ca' must be a string"},
      {"[security]\ngovernance = \"governance.p7s\"", DdsConfigErrc::kOutOfRange,
       "'security.governance' must be an absolute path"},
      {"[security]\nprivate_key = \"\"", DdsConfigErrc::kOutOfRange, "'security.private_key'"},
      {"[security]\nidentity = \"/a\"", DdsConfigErrc::kUnknownKey, "'security.identity'"},
  };
  for (const Case& c : cases) {
    const DdsConfigResult r = parse_dds_config(c.text);
    EXPECT_EQ(r.error.code, make_error_code(c.code)) << c.text;
    EXPECT_NE(r.error.message.find(c.mentions), std::string::npos) << c.text << " -> " << r.error.message;
    EXPECT_EQ(r.error.message.rfind("config: ", 0), 0u) << r.error.message;
  }
}

// OMG DDS Security 1.1, 9.3.1 (authentication: identity CA, identity
// certificate, private key) and 9.4.1 (access control: permissions CA,
// governance, permissions): the builtin plugins need all six, so
// [outputs.dds.security] is all six or none. A partial set, an empty table
// included, is refused naming every missing key, before any file is read.
TEST(DdsConfig, OmgDdsSec11_9_3_1_and_9_4_1_SecurityIsAllSixFilesOrNone) {
  const char* keys[] = {"identity_ca", "identity_certificate", "private_key", "permissions_ca", "governance",
                        "permissions"};
  for (const char* left_out : keys) {
    std::string text = "[security]\n";
    for (const char* k : keys)
      if (k != left_out) text += std::string(k) + " = \"/nonexistent/" + k + "\"\n";
    const DdsConfigResult r = parse_dds_config(text);
    EXPECT_EQ(r.error.code, make_error_code(DdsConfigErrc::kMissingKey)) << left_out << ": " << r.error.message;
    EXPECT_NE(r.error.message.find("missing 'security." + std::string(left_out) + "'"), std::string::npos)
        << r.error.message;
    EXPECT_EQ(r.error.message.find("/nonexistent"), std::string::npos) << "no file is looked at: " << r.error.message;
  }
  const DdsConfigResult empty = parse_dds_config("[security]\n");
  EXPECT_EQ(empty.error.code, make_error_code(DdsConfigErrc::kMissingKey));
  for (const char* k : keys)
    EXPECT_NE(empty.error.message.find("'security." + std::string(k) + "'"), std::string::npos) << k;
  const DdsConfigResult two = parse_dds_config("[security]\nidentity_ca = \"/a\"\ngovernance = \"/b\"\n");
  EXPECT_NE(two.error.message.find("missing 'security.identity_certificate', 'security.private_key', "
                             "'security.permissions_ca', 'security.permissions'"),
            std::string::npos)
      << two.error.message;
}

}  // namespace
