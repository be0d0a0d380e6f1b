// cobridge-sim's command line: --device belongs to the --iface before it,
// serial assignment, and errors that name the argument (exit code 2).
#include "app/command_line.hpp"

#include <gtest/gtest.h>

#include <array>
#include <filesystem>

namespace cobridge::sim {
namespace {

constexpr std::array<ModelInfo, 2> kModels{{
    {"RFC-4800", FamilyId::novotechnik_rotary, 0x182, 0x0BE0, 127, false, "novotechnik-rfc4800", 250},
    {"RM9000", FamilyId::ifm_rm, 0x0069666D, 0x4341, 32, false, "ifm-rm8-rm9", 125},
}};

const ModelInfo* lookup(std::string_view name) noexcept {
  for (const ModelInfo& m : kModels)
    if (m.name == name) return &m;
  return nullptr;
}

CommandLineResult parse(std::vector<std::string> args, std::filesystem::path installed = "/nonexistent/devices",
                        std::filesystem::path source = std::filesystem::temp_directory_path()) {
  std::vector<const char*> argv{"cobridge-sim"};
  for (const auto& a : args) argv.push_back(a.c_str());
  return parse_command_line(static_cast<int>(argv.size()), argv.data(), &lookup, kModels, installed, source);
}

TEST(CommandLine, DevicesBelongToThePrecedingIface) {
  const auto r = parse({"--iface", "vcan0", "--device", "RFC-4800", "--device", "RM9000:serial=10", "--iface=vcan1",
                        "--device=RFC-4800:node=3"});
  ASSERT_EQ(r.exit_code(), -1) << r.output();
  ASSERT_EQ(r.options.buses.size(), 2u);
  EXPECT_EQ(r.options.buses[0].iface, "vcan0");
  ASSERT_EQ(r.options.buses[0].devices.size(), 2u);
  EXPECT_EQ(r.options.buses[0].devices[0].model->name, "RFC-4800");
  EXPECT_EQ(r.options.buses[0].devices[1].model->name, "RM9000");
  EXPECT_EQ(r.options.buses[1].iface, "vcan1");
  ASSERT_EQ(r.options.buses[1].devices.size(), 1u);
  EXPECT_EQ(r.options.buses[1].devices[0].node_id, 3);
  // Serials not given count up from 1; the given one (10) is kept.
  EXPECT_EQ(r.options.buses[0].devices[0].serial, 1u);
  EXPECT_EQ(r.options.buses[0].devices[1].serial, 10u);
  EXPECT_EQ(r.options.buses[1].devices[0].serial, 2u);
}

TEST(CommandLine, AutomaticSerialsSkipGivenOnes) {
  const auto r = parse({"--iface", "vcan0", "--device", "RFC-4800", "--device", "RFC-4800:serial=2", "--device",
                        "RFC-4800"});
  ASSERT_EQ(r.exit_code(), -1) << r.output();
  EXPECT_EQ(r.options.buses[0].devices[0].serial, 1u);
  EXPECT_EQ(r.options.buses[0].devices[2].serial, 3u);
}

TEST(CommandLine, PathsAndDevicesDirFallback) {
  const auto src = std::filesystem::temp_directory_path();
  const auto r = parse({"--iface", "vcan0", "--device", "RM9000", "--state-dir", "/tmp/s", "--truth", "/tmp/t",
                        "--control", "/tmp/c"},
                       "/nonexistent/devices", src);
  ASSERT_EQ(r.exit_code(), -1) << r.output();
  EXPECT_EQ(r.options.state_dir, "/tmp/s");
  EXPECT_EQ(r.options.truth_file, "/tmp/t");
  EXPECT_EQ(r.options.control_path, "/tmp/c");
  EXPECT_EQ(r.options.devices_dir, src);  // installed dir missing -> source tree
}

TEST(CommandLine, HelpDocumentsKeysAndControlCommands) {
  const auto r = parse({"--help"});
  EXPECT_EQ(r.exit_code(), 0);
  for (const char* s : {"--iface", "--device", "--state-dir", "--truth", "--control", "--devices-dir", "serial=",
                        "node=", "channels=", "bitrate=", "lss=", "segmented=", "motion=", "power-cycle", "silence",
                        "fault", "move", "flood", "babble", "bus-error", "RFC-4800", "RM9000"})
    EXPECT_NE(r.output().find(s), std::string::npos) << s;
}

TEST(CommandLine, ErrorsExitWithTwoAndNameTheArgument) {
  struct Case {
    std::vector<std::string> args;
    const char* expect;
  };
  const std::vector<Case> cases{
      {{}, "--iface"},
      {{"--iface", "vcan0"}, "--device"},
      {{"--device", "RFC-4800", "--iface", "vcan0"}, "comes before any --iface"},
      {{"--iface", "vcan0", "--device", "RFC-4800:node=200"}, "node must be 1..127"},
      {{"--iface", "vcan0", "--device", "XYZ"}, "unknown model 'XYZ'"},
      {{"--iface", "vcan0", "--device", "RFC-4800", "--iface", "vcan1"}, "'vcan1' has no --device"},
      {{"--iface", "vcan0", "--device", "RFC-4800", "--iface", "vcan0", "--device", "RM9000"}, "given twice"},
      {{"--iface", "this-name-is-far-too-long", "--device", "RFC-4800"}, "not an interface name"},
      {{"--iface", "vcan0", "--device", "RFC-4800:serial=5", "--device", "RM9000:serial=5"}, "serial 5 is used by two"},
      {{"--iface", "vcan0", "--device", "RFC-4800", "--devices-dir", "/nonexistent"}, "--devices-dir"},
      {{"--iface", "vcan0", "--device", "RFC-4800", "--bogus"}, "--bogus"},
  };
  for (const Case& c : cases) {
    const auto r = parse(c.args);
    EXPECT_EQ(r.exit_code(), 2) << c.expect;
    EXPECT_NE(r.output().find(c.expect), std::string::npos) << r.output();
  }
}

TEST(CommandLine, NoDescriptionsAnywhereIsAnError) {
  const auto r = parse({"--iface", "vcan0", "--device", "RFC-4800"}, "/nonexistent/a", "/nonexistent/b");
  EXPECT_EQ(r.exit_code(), 2);
  EXPECT_NE(r.output().find("--devices-dir"), std::string::npos);
}

}  // namespace
}  // namespace cobridge::sim
