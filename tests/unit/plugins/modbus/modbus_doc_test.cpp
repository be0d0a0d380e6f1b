// docs/modbus.md must describe the map the plugin serves: its four register
// tables (gateway, bus, controller, device slot), read in document order, list exactly
// the registers of register_map.cpp with the same offsets, names and types.
#include "register_map.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

namespace cobridge::modbus {
namespace {

struct DocRow {
  int offset;
  std::string name;
  std::string type;
};

std::vector<DocRow> doc_rows() {
  const auto path = std::filesystem::path(__FILE__).parent_path() / "../../../../docs/modbus.md";
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  // | +4..5 | `uptime` | uint32 | ...
  const std::regex row(R"(^\| \+(\d+)(?:\.\.\d+)? \| `([a-z_]+)` \| (u?int(?:16|32)) \|)");
  std::vector<DocRow> rows;
  std::string line;
  std::smatch m;
  while (std::getline(in, line)) {
    if (std::regex_search(line, m, row)) rows.push_back({std::stoi(m[1]), m[2], m[3]});
  }
  return rows;
}

TEST(ModbusDoc, RegisterTablesMatchTheMap) {
  std::vector<const RegisterDef*> defs;
  for (const auto& d : gateway_registers()) defs.push_back(&d);
  for (const auto& d : bus_registers()) defs.push_back(&d);
  for (const auto& d : controller_registers()) defs.push_back(&d);
  for (const auto& d : device_registers()) defs.push_back(&d);
  const std::vector<DocRow> rows = doc_rows();
  ASSERT_EQ(rows.size(), defs.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i].offset, defs[i]->offset) << defs[i]->name;
    EXPECT_EQ(rows[i].name, defs[i]->name);
    EXPECT_EQ(rows[i].type, type_name(defs[i]->type)) << defs[i]->name;
  }
}

}  // namespace
}  // namespace cobridge::modbus
