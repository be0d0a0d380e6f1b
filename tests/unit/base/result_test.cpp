// base/result: a value or the Error that prevented it.
#include "base/result.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <system_error>
#include <variant>

namespace {

using cobridge::Errc;
using cobridge::Error;
using cobridge::Result;

Result<int> half(int n) {
  if (n % 2 != 0) return Error(Errc::kInvalidArgument, "odd", "n", std::make_error_code(std::errc::invalid_argument));
  return n / 2;
}

TEST(Result, HoldsTheValueOnSuccess) {
  Result<int> r = half(8);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r.value(), 4);
  EXPECT_EQ(*r, 4);
  EXPECT_TRUE(r.error().ok());
  EXPECT_EQ(r.value_or(-1), 4);
}

TEST(Result, HoldsTheWholeErrorOnFailure) {
  Result<int> r = half(7);
  ASSERT_FALSE(r.ok());
  const Error e = r.error();
  EXPECT_EQ(e.kind, Errc::kInvalidArgument);
  EXPECT_EQ(e.message, "odd");
  EXPECT_EQ(e.where, "n");
  EXPECT_EQ(e.code, std::errc::invalid_argument);
  EXPECT_EQ(r.value_or(-1), -1);
  EXPECT_THROW(static_cast<void>(r.value()), std::bad_variant_access);
}

TEST(Result, AnOkErrorStillMeansFailure) {
  Result<std::string> r = Error{};
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.error().kind, Errc::kInternal);
}

TEST(Result, MovesItsContentsOut) {
  Result<std::unique_ptr<int>> r = std::make_unique<int>(5);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(*r->get(), 5);
  std::unique_ptr<int> p = std::move(r).value();
  EXPECT_EQ(*p, 5);

  Result<std::string> f = Error(Errc::kNotFound, "no such bus", "bus 'x'");
  const Error e = std::move(f).error();
  EXPECT_EQ(e.to_string(), "bus 'x': no such bus");
}

}  // namespace
