// check_outputs (--check-config) reports an output the plugin host cannot
// load as the project's one error shape: where = the
// [outputs.<name>] header's place, message = the plugin file and the reason,
// code = the PluginErrc.
#include "outputs/output_pipeline.hpp"

#include <gtest/gtest.h>

using namespace cobridge;

TEST(CheckOutputs, MissingPluginIsAnErrorAtItsSection) {
  config::Config cfg;
  config::Output out;
  out.name = "nosuch";
  out.where = {"/etc/cobridge/cobridge.toml", 30, 1};
  cfg.outputs.push_back(out);
  config::Output off = out;
  off.name = "off";
  off.enabled = false;  // a disabled output is not loaded, so not checked
  cfg.outputs.push_back(off);

  const std::vector<Error> errors = outputs::check_outputs(cfg, "/nonexistent-plugin-dir");
  ASSERT_EQ(errors.size(), 1U);
  const Error& e = errors[0];
  EXPECT_EQ(e.kind, Errc::kNotFound);
  EXPECT_EQ(e.code, pipeline::PluginErrc::kFileNotFound);
  EXPECT_EQ(e.where, "/etc/cobridge/cobridge.toml:30:1: [outputs.nosuch]");
  EXPECT_EQ(e.message, "/nonexistent-plugin-dir/libcobridge_nosuch.so: file not found");
  EXPECT_EQ(e.to_string(), "/etc/cobridge/cobridge.toml:30:1: [outputs.nosuch]: "
                           "/nonexistent-plugin-dir/libcobridge_nosuch.so: file not found")
      << "the text --check-config prints";
}
