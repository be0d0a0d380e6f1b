// DDS Security for the DDS output (dds_security.hpp; docs/dds.md,
// "Security"): the files checked at load, the participant QoS properties of
// Cyclone DDS's builtin plugins (OMG DDS Security 1.1, 9.3 authentication
// PKI-DH, 9.4 access control Permissions, 9.5 cryptography AES-GCM-GMAC),
// and Cyclone securing a participant with them. Credentials come from
// scripts/dds-test-ca (unit/plugins/dds/test_ca.hpp).
#include "dds/dds_config.hpp"
#include "dds/dds_security.hpp"
#include "unit/plugins/dds/test_ca.hpp"

#include <dds/dds.h>
#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

using namespace cobridge::dds;
using cobridge::dds::test::TestCa;

namespace {

// Before any participant exists: loopback only (the participant tests).
const bool kLoopback = [] {
  ::setenv("CYCLONEDDS_URI",
           "<General><Interfaces><NetworkInterface name=\"lo\" multicast=\"true\"/></Interfaces></General>", 1);
  return true;
}();

std::uint32_t test_domain() { return 20u + static_cast<std::uint32_t>(::getpid()) % 200u; }

// The gateway's table with one key's value replaced.
std::string with(const std::string& key, const std::string& value) {
  std::string t = TestCa::get().table();
  const auto at = t.find("\n" + key + " = ");
  const auto end = t.find('\n', at + 1);
  return t.replace(at + 1, end - at - 1, key + " = \"" + value + "\"");
}

// A scratch file beside the test CA's, with `text` and `mode`.
std::string scratch(const std::string& name, const std::string& text, mode_t mode) {
  const std::string path = TestCa::get().file(name);
  std::ofstream(path) << text;
  ::chmod(path.c_str(), mode);
  return path;
}

// OMG DDS Security 1.1, 9.3.1 / 9.4.1: the test CA's full set is accepted
// and the identity certificate's subject read, in the RFC 2253 form a
// permissions document's subject_name uses.
TEST(DdsSecurity, OmgDdsSec11_9_3_1_FullSetIsReadWithTheIdentitySubject) {
  const DdsConfigResult r = parse_dds_config(TestCa::get().table());
  ASSERT_TRUE(r.ok()) << r.error.message;
  ASSERT_TRUE(r.config.security.has_value());
  const DdsSecurity& s = *r.config.security;
  EXPECT_EQ(s.identity_certificate, TestCa::get().file("gateway.pem"));
  EXPECT_EQ(s.permissions, TestCa::get().file("gateway_permissions.p7s"));
  EXPECT_EQ(s.subject, "CN=gateway,O=cobridge test");
  EXPECT_EQ(s.not_after.size(), 20u) << s.not_after;  // 2026-12-27T16:10:36Z
  EXPECT_EQ(s.plugin_dir, default_security_plugin_dir());
}

// docs/dds.md "Security": each of the six files must exist and be readable
// when the configuration is loaded; the error names the key and the path.
TEST(DdsSecurity, DocsDds_EveryFileMustExistAndBeReadable) {
  for (const SecurityFileKey& k : kSecurityFileKeys) {
    const std::string missing = "/nonexistent/cobridge/" + std::string(k.key) + ".pem";
    const DdsConfigResult r = parse_dds_config(with(std::string(k.key), missing));
    EXPECT_EQ(r.error.code, make_error_code(DdsConfigErrc::kBadFile)) << k.key << ": " << r.error.message;
    EXPECT_NE(r.error.message.find("'security." + std::string(k.key) + "'"), std::string::npos) << r.error.message;
    EXPECT_NE(r.error.message.find(missing), std::string::npos) << r.error.message;
    EXPECT_NE(r.error.message.find("No such file"), std::string::npos) << r.error.message;
  }
  const DdsConfigResult dir = parse_dds_config(with("governance", "/tmp"));
  EXPECT_EQ(dir.error.code, make_error_code(DdsConfigErrc::kBadFile));
  EXPECT_NE(dir.error.message.find("not a regular file"), std::string::npos) << dir.error.message;
  const DdsConfigResult empty = parse_dds_config(with("permissions", scratch("empty.p7s", "", 0644)));
  EXPECT_EQ(empty.error.code, make_error_code(DdsConfigErrc::kBadFile));
  EXPECT_NE(empty.error.message.find("empty"), std::string::npos) << empty.error.message;
}

// docs/dds.md "Security": a private key that group or others may read (or
// write) is refused: whoever reads it can pose as the gateway.
TEST(DdsSecurity, DocsDds_PrivateKeyOpenToGroupOrOthersIsRefused) {
  std::ifstream in(TestCa::get().file("gateway_key.pem"));
  const std::string key((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const mode_t mode : {0640u, 0604u, 0620u, 0644u}) {
    const std::string path = scratch("open_key.pem", key, mode);
    const DdsConfigResult r = parse_dds_config(with("private_key", path));
    EXPECT_EQ(r.error.code, make_error_code(DdsConfigErrc::kBadFile)) << std::oct << mode;
    EXPECT_NE(r.error.message.find("'security.private_key' (" + path + ")"), std::string::npos) << r.error.message;
    EXPECT_NE(r.error.message.find("chmod 600"), std::string::npos) << r.error.message;
  }
  for (const mode_t mode : {0600u, 0400u}) {
    const DdsConfigResult r = parse_dds_config(with("private_key", scratch("closed_key.pem", key, mode)));
    EXPECT_TRUE(r.ok()) << std::oct << mode << ": " << r.error.message;
  }
  // The other files are public: a certificate at 0644 is fine (above).
}

// The identity certificate is read at load: something else there is named.
TEST(DdsSecurity, DocsDds_IdentityCertificateMustBeAPemCertificate) {
  const DdsConfigResult r = parse_dds_config(with("identity_certificate", TestCa::get().file("governance.xml")));
  EXPECT_EQ(r.error.code, make_error_code(DdsConfigErrc::kBadFile));
  EXPECT_NE(r.error.message.find("'security.identity_certificate'"), std::string::npos) << r.error.message;
  EXPECT_NE(r.error.message.find("not a PEM X.509 certificate"), std::string::npos) << r.error.message;
}

// Debian 12 installs the builtin plugins outside the library search path:
// a folder without them is an error that names the file and the package.
TEST(DdsSecurity, DocsDds_MissingPluginLibrariesAreNamed) {
  const DdsConfigResult r = parse_dds_config(TestCa::get().table() + "plugin_dir = \"/nonexistent/lib\"\n");
  EXPECT_EQ(r.error.code, make_error_code(DdsConfigErrc::kBadFile));
  EXPECT_NE(r.error.message.find("/nonexistent/lib/libdds_security_auth.so"), std::string::npos) << r.error.message;
  EXPECT_NE(r.error.message.find("libddsc0debian"), std::string::npos) << r.error.message;
  // This build found them (plugins/dds/CMakeLists.txt).
  for (const std::string_view f : kSecurityPluginFiles) {
    const std::string path = std::string(default_security_plugin_dir()) + "/" + std::string(f);
    EXPECT_EQ(::access(path.c_str(), R_OK), 0) << path;
  }
}

// OMG DDS Security 1.1, 9.3.1 and 9.4.1 (the builtin plugins' properties)
// as Cyclone DDS 0.10 names them: each plugin by library path, init and
// finalize function; the six documents as file: URIs. Literal names here,
// not the header's macros, so that a wrong macro would show.
TEST(DdsSecurity, OmgDdsSec11_9_3_1_and_9_4_1_QosCarriesTheBuiltinPluginProperties) {
  const DdsSecurity s = *parse_dds_config(TestCa::get().table()).config.security;
  dds_qos_t* q = dds_create_qos();
  set_security_properties(q, s);
  const std::string dir(default_security_plugin_dir());
  const std::pair<const char*, std::string> expected[] = {
      {"dds.sec.auth.library.path", dir + "/libdds_security_auth.so"},
      {"dds.sec.auth.library.init", "init_authentication"},
      {"dds.sec.auth.library.finalize", "finalize_authentication"},
      {"dds.sec.access.library.path", dir + "/libdds_security_ac.so"},
      {"dds.sec.access.library.init", "init_access_control"},
      {"dds.sec.access.library.finalize", "finalize_access_control"},
      {"dds.sec.crypto.library.path", dir + "/libdds_security_crypto.so"},
      {"dds.sec.crypto.library.init", "init_crypto"},
      {"dds.sec.crypto.library.finalize", "finalize_crypto"},
      {"dds.sec.auth.identity_ca", "file:" + s.identity_ca},
      {"dds.sec.auth.identity_certificate", "file:" + s.identity_certificate},
      {"dds.sec.auth.private_key", "file:" + s.private_key},
      {"dds.sec.access.permissions_ca", "file:" + s.permissions_ca},
      {"dds.sec.access.governance", "file:" + s.governance},
      {"dds.sec.access.permissions", "file:" + s.permissions},
  };
  for (const auto& [name, value] : expected) {
    char* got = nullptr;
    ASSERT_TRUE(dds_qget_prop(q, name, &got)) << name;
    EXPECT_EQ(std::string(got), value) << name;
    dds_free(got);
  }
  dds_delete_qos(q);
}

dds_entity_t secured_participant(const DdsSecurity& s) {
  dds_qos_t* q = dds_create_qos();
  set_security_properties(q, s);
  const dds_entity_t pp = dds_create_participant(static_cast<dds_domainid_t>(test_domain()), q, nullptr);
  dds_delete_qos(q);
  return pp;
}

// OMG DDS Security 1.1, 8.8.1 (participant creation validates the local
// identity, 9.3, and permissions, 9.4): Cyclone creates a participant with
// the gateway's credentials, and refuses one whose permissions document
// names another subject, which shows the plugins are really in charge.
TEST(DdsSecurity, OmgDdsSec11_8_8_1_CycloneSecuresTheParticipant) {
  DdsSecurity s = *parse_dds_config(TestCa::get().table()).config.security;
  const dds_entity_t pp = secured_participant(s);
  EXPECT_GT(pp, 0) << dds_strretcode(pp);
  if (pp > 0) dds_delete(pp);

  s.permissions = TestCa::get().file("reader-all_permissions.p7s");  // CN=reader-all's grant
  const dds_entity_t refused = secured_participant(s);
  EXPECT_LT(refused, 0) << "a permissions document of another subject must not be accepted";
  if (refused > 0) dds_delete(refused);
}

// docs/dds.md "Security": the start says whether DDS is secured, and as whom.
TEST(DdsSecurity, DocsDds_LogLineSaysOnWithTheSubjectOrOffWithTheRisk) {
  EXPECT_EQ(security_log_line(nullptr), "DDS Security: off (any participant on the network may read the topics)");
  const DdsSecurity s = *parse_dds_config(TestCa::get().table()).config.security;
  const std::string on = security_log_line(&s);
  EXPECT_EQ(on.rfind("DDS Security: on, identity 'CN=gateway,O=cobridge test'", 0), 0u) << on;
  EXPECT_NE(on.find(s.permissions), std::string::npos) << on;
}

}  // namespace
