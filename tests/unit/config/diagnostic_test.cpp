// Diagnostic as the project's one error shape (daemon/base/error.hpp):
// a configuration problem is bad input (kInvalidArgument) whose where is the
// compiler-style place "file:line:column" (just "file" for the whole file).
#include "config/diagnostic.hpp"

#include "config/config.hpp"
#include "config/load.hpp"

#include <gtest/gtest.h>

#include <filesystem>

namespace cobridge::config {
namespace {

TEST(DiagnosticError, PlaceIsWhereAndMessageIsKept) {
  const Diagnostic d{"/etc/cobridge/cobridge.toml", 7, 11, "bus \"line1\": bitrate must be an integer, got string"};
  const Error e = to_error(d);
  EXPECT_EQ(e.kind, Errc::kInvalidArgument);
  EXPECT_EQ(e.where, "/etc/cobridge/cobridge.toml:7:11");
  EXPECT_EQ(e.message, d.message);
  EXPECT_FALSE(e.code) << "the loader knows no finer code than the message";
  EXPECT_EQ(e.to_string(), to_string(d)) << "one text in the log, the CLI and --check-config";
  EXPECT_EQ(e.to_string(), "/etc/cobridge/cobridge.toml:7:11: bus \"line1\": bitrate must be an integer, got string");
}

TEST(DiagnosticError, WholeFileHasNoLineInWhere) {
  const Diagnostic d{"cobridge.toml", 0, 0, "cannot read the configuration file"};
  const Error e = to_error(d);
  EXPECT_EQ(e.where, "cobridge.toml");
  EXPECT_EQ(to_string(d), "cobridge.toml: cannot read the configuration file");
}

TEST(DiagnosticError, SourceLocationGivesTheSamePlace) {
  EXPECT_EQ((SourceLocation{"a.toml", 3, 1}.to_string()), "a.toml:3:1");
  EXPECT_EQ((SourceLocation{"a.toml", 0, 0}.to_string()), "a.toml");
}

// Every diagnostic of a real failed load converts with its place.
TEST(DiagnosticError, LoadedDiagnosticsConvert) {
  const std::filesystem::path missing = "/nonexistent-dir/cobridge.toml";
  const LoadResult r = load(missing);
  ASSERT_FALSE(r.ok());
  ASSERT_FALSE(r.diagnostics().empty());
  const Error e = to_error(r.diagnostics().front());
  EXPECT_EQ(e.kind, Errc::kInvalidArgument);
  EXPECT_EQ(e.where, missing.string());
  EXPECT_NE(e.message.find("cannot"), std::string::npos) << e.message;
}

}  // namespace
}  // namespace cobridge::config
