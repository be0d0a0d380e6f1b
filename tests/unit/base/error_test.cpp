// base/error: the one failure shape.
#include "base/error.hpp"

#include <gtest/gtest.h>

#include <system_error>

namespace cobridge {
namespace {

TEST(Error, DefaultIsOk) {
  const Error e;
  EXPECT_TRUE(e.ok());
  EXPECT_FALSE(static_cast<bool>(e));
}

TEST(Error, ToStringPutsWhereFirst) {
  const Error e(Errc::kInvalidArgument, "cam 5 does not exist (E§3.4: 4 CAMs)", "device 'lift'");
  EXPECT_EQ(e.to_string(), "device 'lift': cam 5 does not exist (E§3.4: 4 CAMs)");
  EXPECT_EQ(Error(Errc::kFailed, "no bus").to_string(), "no bus");
}

TEST(Error, ExitCodesAreTheKindNumbers) {
  EXPECT_EQ(exit_code(Errc::kOk), 0);
  EXPECT_EQ(exit_code(Errc::kFailed), 1);
  EXPECT_EQ(exit_code(Errc::kInvalidArgument), 2);
  EXPECT_EQ(exit_code(Errc::kTimeout), 3);
  EXPECT_EQ(exit_code(Errc::kPermissionDenied), 4);
  EXPECT_EQ(exit_code(Errc::kUnavailable), 5);
  EXPECT_EQ(exit_code(Errc::kNotFound), 6);
}

TEST(Error, JsonCarriesKindWhereMessageAndDetail) {
  const Error e(Errc::kTimeout, "no \"answer\"\n", "bus 'line1' node 10",
                std::make_error_code(std::errc::timed_out));
  const std::string j = e.to_json();
  EXPECT_NE(j.find("\"code\":\"timeout\""), std::string::npos) << j;
  EXPECT_NE(j.find("\"where\":\"bus 'line1' node 10\""), std::string::npos) << j;
  EXPECT_NE(j.find("\"message\":\"no \\\"answer\\\"\\n\""), std::string::npos) << j;
  EXPECT_NE(j.find("\"category\":\"generic\""), std::string::npos) << j;
}

TEST(Error, JsonWithoutPreciseCodeHasNoDetail) {
  EXPECT_EQ(Error(Errc::kNotFound, "m", "w").to_json(),
            R"({"code":"not_found","where":"w","message":"m"})");
}

TEST(JsonQuote, EscapesControlCharacters) {
  EXPECT_EQ(json_quote(std::string_view("a\x01", 2)), "\"a\\u0001\"");
}

}  // namespace
}  // namespace cobridge
