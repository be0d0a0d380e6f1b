// The register map definition shared by the plugin and `cobridge modbus-map`
// (docs/modbus.md): the CSV export and its agreement with the image.
#include "register_image.hpp"
#include "register_map.hpp"

#include <gtest/gtest.h>

#include <set>
#include <sstream>
#include <string>

namespace cobridge::modbus {
namespace {

// docs/modbus.md "Device slots": slot n at 256 + 32 n, position at +0, data age at +11.
TEST(RegisterMap, SlotAddressesFollowTheStride) {
  EXPECT_EQ(device_base(0), 256);
  EXPECT_EQ(device_base(3), 256 + 96);
  EXPECT_EQ(map_size(32), 256u + 32u * 32u);
  const auto rows = map_rows(1, 2);
  bool found = false;
  for (const MapRow& r : rows) {
    if (r.name == "device[1].data_age") {
      EXPECT_EQ(r.address, 256 + 32 + 11);
      found = true;
    }
  }
  EXPECT_TRUE(found);
}

// docs/modbus.md "Controller block": bus b's error counters at 144 + 4 b,
// after the 16 bus blocks and before the device slots.
TEST(RegisterMap, ControllerBlocksSitBetweenBusBlocksAndSlots) {
  EXPECT_EQ(controller_base(0), 144);
  EXPECT_EQ(controller_base(15), 144 + 60);
  EXPECT_LE(controller_base(kMaxBuses), kDeviceBase);
  EXPECT_EQ(bus_base(kMaxBuses), controller_base(0)) << "no gap, no overlap";
}

// RFC 4180 CSV with the columns SCADA import expects; one row per value.
TEST(RegisterMap, CsvHasHeaderAndOneRowPerValue) {
  const std::string csv = map_csv(2, 3);
  std::istringstream in(csv);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "address,name,type,unit,scale,access,description\r");
  std::size_t rows = 0;
  std::set<std::string> names;
  while (std::getline(in, line)) {
    ++rows;
    names.insert(line.substr(0, line.find(',', line.find(',') + 1)));
  }
  const std::size_t expected = gateway_registers().size() + 2 * bus_registers().size() +
                               2 * controller_registers().size() + 3 * device_registers().size();
  EXPECT_EQ(rows, expected);
  EXPECT_EQ(names.size(), expected);  // no duplicate address/name
  EXPECT_NE(csv.find("\r\n16,bus[0].state,uint16,,1,R,"), std::string::npos);
  EXPECT_NE(csv.find("\r\n27,bus[1].controller_state,uint16,,1,R,"), std::string::npos);
  EXPECT_NE(csv.find("\r\n148,controller[1].tx_errors,uint16,,1,R,"), std::string::npos);
  EXPECT_NE(csv.find("\r\n150,controller[1].restarts,uint32,,1,R,"), std::string::npos);
  EXPECT_NE(csv.find("\r\n272,device[0].temperature,int16,degC,0.1,R,device temperature\r\n"), std::string::npos);
  EXPECT_NE(csv.find("\r\n256,device[0].position,int32,counts,1,R,\"position after"), std::string::npos);  // quoted (comma)
}

// Every defined register is readable through the image (the map and the
// renderer agree), and a 32-bit value never straddles two blocks.
TEST(RegisterMap, EveryRowIsReadable) {
  ImageOptions o;
  o.device_slots = 2;
  RegisterImage img(o);
  for (const MapRow& r : map_rows(kMaxBuses, 2)) {
    std::array<std::uint16_t, 2> v{};
    const std::uint16_t n = word_count(r.def->type);
    EXPECT_EQ(img.read(r.address, std::span(v.data(), n), ReadTime{}, false), ReadStatus::kOk) << r.name;
  }
}

}  // namespace
}  // namespace cobridge::modbus
