// Per-module loggers and levels (style: one named logger per module).
#include "sys/logging.hpp"

#include <gtest/gtest.h>

using namespace cobridge::sys;

TEST(Logging, OneNamedLoggerPerModule) {
  setup_logging(LogTarget::console);
  auto a = logger("can");
  auto b = logger("can");
  auto c = logger("canopen");
  EXPECT_EQ(a.get(), b.get());
  EXPECT_NE(a.get(), c.get());
  EXPECT_EQ(a->name(), "can");
}

TEST(Logging, LevelPerModuleAndRejectsUnknownLevel) {
  setup_logging(LogTarget::console);
  EXPECT_TRUE(set_level("gateway", "debug"));
  EXPECT_EQ(logger("gateway")->level(), spdlog::level::debug);
  EXPECT_EQ(logger("modbus")->level(), spdlog::level::info);
  EXPECT_FALSE(set_level("gateway", "verbose"));
  EXPECT_EQ(logger("gateway")->level(), spdlog::level::debug);
  EXPECT_TRUE(set_level("gateway", "off"));
  EXPECT_EQ(logger("gateway")->level(), spdlog::level::off);
}
