// DCMD decoding (Sparkplug 3.0 6.4.x "DCMD": a host writes metrics the
// device's DBIRTH declared, by name or by alias, tck-id-payloads-dcmd-*):
// one command and its sender, or a reason that names the metric.
#include "dcmd_request.hpp"
#include "sparkplug_payload.hpp"

#include <gtest/gtest.h>

#include <array>
#include <string>

namespace cobridge::mqtt {
namespace {

class Dcmd {
 public:
  Dcmd() { b_.begin(1, std::nullopt); }
  Dcmd& client(const char* who) {
    EXPECT_TRUE(b_.add_string("Command/Client", 0, 1, DataType::kString, who));
    return *this;
  }
  Dcmd& scalar(const char* name, std::uint64_t alias, DataType t, std::int64_t v) {
    EXPECT_TRUE(b_.add_scalar(name, alias, 1, t, Scalar{v, 0.0}));
    return *this;
  }
  DcmdRequest parse(const char* device = "rot") {
    const std::size_t n = b_.pack(buf_);
    return parse_dcmd(device, buf_.data(), n);
  }

 private:
  PayloadBuilder b_;
  std::array<std::uint8_t, 1024> buf_{};
};

TEST(DcmdRequest, Spec64_PresetByNameWithClient) {
  const DcmdRequest r = Dcmd().client("scada-1").scalar("Command/Preset", 0, DataType::kInt64, -1234).parse();
  EXPECT_EQ(r.kind, COBRIDGE_COMMAND_PRESET) << r.error;
  EXPECT_EQ(r.value, -1234);  // two's complement in long_value (spec 6.4.4)
  EXPECT_STREQ(r.client, "scada-1");
  EXPECT_STREQ(r.device_id, "rot");
  EXPECT_EQ(r.alias_device, -1);
}

// By alias only (spec 6.4.4: a host may use the DBIRTH's aliases); the alias
// tells the device it belongs to.
TEST(DcmdRequest, Spec644_StoreByAliasNamesItsDevice) {
  const DcmdRequest r =
      Dcmd().client("c").scalar(nullptr, device_alias(2, DeviceMetric::kCmdStore), DataType::kBoolean, 1).parse();
  EXPECT_EQ(r.kind, COBRIDGE_COMMAND_STORE) << r.error;
  EXPECT_EQ(r.alias_device, 2);
  const DcmdRequest reset = Dcmd().client("c").scalar("Command/NMT Reset", 0, DataType::kBoolean, 1).parse();
  EXPECT_EQ(reset.kind, COBRIDGE_COMMAND_NMT_RESET) << reset.error;
}

TEST(DcmdRequest, BadPayloadsSayWhatAndWhere) {
  struct Case {
    DcmdRequest r;
    const char* needle;
  };
  const std::uint8_t junk[] = {0xFF, 0xFF, 0xFF, 0x01};
  const Case cases[] = {
      {parse_dcmd("rot", junk, sizeof junk), "not a Sparkplug B payload"},
      {parse_dcmd("rot", nullptr, 0), "not a Sparkplug B payload"},
      {Dcmd().client("c").scalar("Command/Reboot", 0, DataType::kBoolean, 1).parse(), "'Command/Reboot'"},
      {Dcmd().client("c").scalar("Position", 0, DataType::kInt64, 1).parse(), "'Position' is not a command"},
      {Dcmd().client("c").scalar("Command/Result Code", 0, DataType::kInt32, 1).parse(), "'Command/Result Code'"},
      {Dcmd().client("c").scalar("Command/Preset", 0, DataType::kBoolean, 1).parse(), "must be an integer"},
      {Dcmd().client("c").scalar("Command/Store", 0, DataType::kBoolean, 0).parse(), "must be the Boolean true"},
      {Dcmd().client("c").scalar("Command/Store", 0, DataType::kInt64, 1).parse(), "must be the Boolean true"},
      {Dcmd().scalar("Command/Preset", 0, DataType::kInt64, 5).parse(), "no Command/Client"},
      {Dcmd().client("c").parse(), "no command metric"},
      {Dcmd().client("").scalar("Command/Store", 0, DataType::kBoolean, 1).parse(), "non-empty String"},
      {Dcmd()
           .client("c")
           .scalar("Command/Store", 0, DataType::kBoolean, 1)
           .scalar("Command/Preset", 0, DataType::kInt64, 1)
           .parse(),
       "one command per DCMD"},
      {Dcmd().client("c").scalar(nullptr, 256u + 99u, DataType::kBoolean, 1).parse(), "alias 355"},
  };
  for (const Case& c : cases) {
    EXPECT_EQ(c.r.kind, 0) << c.needle;
    EXPECT_NE(std::string(c.r.error).find(c.needle), std::string::npos) << c.r.error;
  }
}

}  // namespace
}  // namespace cobridge::mqtt
