// PlanError as the project's one error shape (daemon/base/error.hpp): the
// configuration's faults are bad input (kInvalidArgument), named by device
// and setting.
#include "bus/config_plan.hpp"

#include <gtest/gtest.h>

using namespace cobridge;

TEST(PlanError, BecomesTheProjectsErrorShape) {
  const bus::PlanError e{"lift", "cam 5", "the multiturn series has 4 CAMs (E§3.4)", false};
  const Error error = e.to_error();
  EXPECT_EQ(error.kind, Errc::kInvalidArgument);
  EXPECT_EQ(error.where, "device 'lift': cam 5");
  EXPECT_EQ(error.message, "the multiturn series has 4 CAMs (E§3.4)");
  EXPECT_EQ(error.to_string(), e.to_string());
}
