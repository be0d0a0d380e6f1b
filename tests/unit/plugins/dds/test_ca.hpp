// A throw-away DDS Security setup for the DDS plugin's tests: made once per
// test process by scripts/dds-test-ca (openssl) in a temporary folder that
// is removed at exit. The repository is located from __FILE__, as in
// unit/device/source_paths.hpp.
#pragma once

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace cobridge::dds::test {

class TestCa {
 public:
  // The folder, made on first use.
  static const TestCa& get() {
    static const TestCa ca;
    return ca;
  }
  [[nodiscard]] std::string file(const std::string& name) const { return (dir_ / name).string(); }
  // The [security] table of `identity` ("gateway", "reader-all", "reader-status").
  [[nodiscard]] std::string table(const std::string& identity = "gateway") const {
    return "[security]\n"
           "identity_ca = \"" + file("identity_ca.pem") + "\"\n"
           "identity_certificate = \"" + file(identity + ".pem") + "\"\n"
           "private_key = \"" + file(identity + "_key.pem") + "\"\n"
           "permissions_ca = \"" + file("permissions_ca.pem") + "\"\n"
           "governance = \"" + file("governance.p7s") + "\"\n"
           "permissions = \"" + file(identity + "_permissions.p7s") + "\"\n";
  }
  TestCa(const TestCa&) = delete;
  TestCa& operator=(const TestCa&) = delete;

 private:
  TestCa() {
    // tests/unit/plugins/dds/test_ca.hpp -> repository root
    auto repo = std::filesystem::path(__FILE__);
    for (int i = 0; i < 5; ++i) repo = repo.parent_path();
    std::string tmpl = (std::filesystem::temp_directory_path() / "cobridge-dds-ca-XXXXXX").string();
    if (::mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    dir_ = tmpl;
    const std::string cmd = "'" + (repo / "scripts" / "dds-test-ca").string() + "' '" + dir_.string() + "' >/dev/null";
    if (std::system(cmd.c_str()) != 0) throw std::runtime_error("scripts/dds-test-ca failed: " + cmd);
  }
  ~TestCa() {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  std::filesystem::path dir_;
};

}  // namespace cobridge::dds::test
