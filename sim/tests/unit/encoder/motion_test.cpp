// Motion grammar of the simulator (DeviceSpec::motion in
// sim/device/sim_device.hpp). No manual section applies: the motion is
// the simulated shaft, the manuals start at the sensor.
#include "encoder/motion.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <unistd.h>

namespace cobridge::sim {
namespace {

Motion parse_ok(const std::string& spec) {
  auto r = Motion::parse(spec);
  EXPECT_TRUE(r.ok()) << spec << ": " << r.error.message;
  return r.motion;
}

TEST(MotionSimGrammar, ConstantIsLinearAndSigned) {
  const auto m = parse_ok("constant:2");
  EXPECT_EQ(m.kind(), Motion::Kind::constant);
  EXPECT_DOUBLE_EQ(m.turns_at(0.0), 0.0);
  EXPECT_DOUBLE_EQ(m.turns_at(1.5), 3.0);
  EXPECT_DOUBLE_EQ(parse_ok("constant:-0.5").turns_at(2.0), -1.0);
  EXPECT_DOUBLE_EQ(Motion{}.turns_at(10.0), 0.0);  // default is constant:0
}

TEST(MotionSimGrammar, SineWithAndWithoutOffset) {
  const auto m = parse_ok("sine:2:4");
  EXPECT_NEAR(m.turns_at(0.0), 0.0, 1e-12);
  EXPECT_NEAR(m.turns_at(1.0), 2.0, 1e-12);
  EXPECT_NEAR(m.turns_at(3.0), -2.0, 1e-12);
  const auto o = parse_ok("sine:1:2:10");
  EXPECT_NEAR(o.turns_at(0.0), 10.0, 1e-12);
  EXPECT_NEAR(o.turns_at(0.5), 11.0, 1e-12);
}

TEST(MotionSimGrammar, StepsArePiecewiseConstant) {
  const auto m = parse_ok("steps:0=0;1=2.5;3=-1");
  EXPECT_DOUBLE_EQ(m.turns_at(-1.0), 0.0);
  EXPECT_DOUBLE_EQ(m.turns_at(0.5), 0.0);
  EXPECT_DOUBLE_EQ(m.turns_at(1.0), 2.5);
  EXPECT_DOUBLE_EQ(m.turns_at(2.999), 2.5);
  EXPECT_DOUBLE_EQ(m.turns_at(3.0), -1.0);
  EXPECT_DOUBLE_EQ(m.turns_at(100.0), -1.0);
  // The first value also holds before the first time.
  EXPECT_DOUBLE_EQ(parse_ok("steps:2=5").turns_at(0.0), 5.0);
}

TEST(MotionSimGrammar, RampGoesUpAndDown) {
  const auto m = parse_ok("ramp:2:4");
  EXPECT_DOUBLE_EQ(m.turns_at(0.0), 0.0);
  EXPECT_DOUBLE_EQ(m.turns_at(1.0), 2.0);
  EXPECT_DOUBLE_EQ(m.turns_at(2.0), 4.0);
  EXPECT_DOUBLE_EQ(m.turns_at(3.0), 2.0);
  EXPECT_DOUBLE_EQ(m.turns_at(4.0), 0.0);
  EXPECT_DOUBLE_EQ(m.turns_at(5.0), 2.0);
  EXPECT_DOUBLE_EQ(parse_ok("ramp:1:-2").turns_at(1.0), -1.0);
}

TEST(MotionSimGrammar, ScriptInterpolatesLinearly) {
  char path[] = "/tmp/motion_test_XXXXXX";
  const int fd = mkstemp(path);
  ASSERT_GE(fd, 0);
  close(fd);
  {
    std::ofstream out(path);
    out << "# time turns\n0 0\n\n1 10   # ten turns after a second\n3 -10\n";
  }
  const auto m = parse_ok(std::string("script:") + path);
  EXPECT_EQ(m.kind(), Motion::Kind::script);
  EXPECT_DOUBLE_EQ(m.turns_at(-1.0), 0.0);
  EXPECT_DOUBLE_EQ(m.turns_at(0.5), 5.0);
  EXPECT_DOUBLE_EQ(m.turns_at(2.0), 0.0);
  EXPECT_DOUBLE_EQ(m.turns_at(9.0), -10.0);
  {
    std::ofstream out(path);
    out << "0 0\n1 oops\n";
  }
  const auto bad = Motion::parse(std::string("script:") + path);
  EXPECT_EQ(bad.error.code, MotionError::bad_script_line);
  EXPECT_NE(bad.error.message.find(":2:"), std::string::npos) << bad.error.message;
  EXPECT_NE(bad.error.message.find("oops"), std::string::npos) << bad.error.message;
  std::remove(path);
}

TEST(MotionSimGrammar, SetOffsetMovesTheShaftByHand) {
  auto m = parse_ok("constant:1");
  m.set_offset(0.25);
  EXPECT_DOUBLE_EQ(m.turns_at(1.0), 1.25);
  EXPECT_DOUBLE_EQ(m.offset(), 0.25);
}

TEST(MotionSimGrammar, ErrorsCarryCodeAndNameTheBadPart) {
  struct Case {
    const char* spec;
    MotionError error;
    const char* names;
  };
  const Case cases[] = {
      {"", MotionError::empty_spec, "empty"},
      {"spin:3", MotionError::unknown_kind, "spin"},
      {"constant:abc", MotionError::bad_number, "abc"},
      {"constant:1:2", MotionError::wrong_field_count, "constant"},
      {"sine:1", MotionError::wrong_field_count, "sine"},
      {"sine:1:0", MotionError::bad_period, "'0'"},
      {"sine:1:x2", MotionError::bad_number, "x2"},
      {"steps:1=1;0.5=2", MotionError::not_increasing, "0.5=2"},
      {"steps:1", MotionError::bad_step, "'1'"},
      {"steps:1=q", MotionError::bad_number, "q"},
      {"ramp:0:3", MotionError::bad_ramp, "turns_per_s"},
      {"ramp:1:0", MotionError::bad_ramp, "max_turns"},
      {"script:/nonexistent/motion.txt", MotionError::cannot_read_script, "/nonexistent/motion.txt"},
  };
  for (const auto& c : cases) {
    const auto r = Motion::parse(c.spec);
    EXPECT_FALSE(r.ok()) << c.spec;
    EXPECT_EQ(r.error.code, c.error) << c.spec << ": " << r.error.message;
    EXPECT_NE(r.error.message.find(c.names), std::string::npos) << c.spec << ": " << r.error.message;
    EXPECT_EQ(r.motion.kind(), Motion::Kind::constant);
  }
  EXPECT_STREQ(make_error_code(MotionError::bad_number).category().name(), "motion");
}

}  // namespace
}  // namespace cobridge::sim
