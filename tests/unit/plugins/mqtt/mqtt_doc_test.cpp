// docs/mqtt.md's metric table must list exactly the metric catalogue of
// sparkplug_metrics.cpp: the same ids (aliases), names and datatypes.
#include "sparkplug_metrics.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <string>

namespace cobridge::mqtt {
namespace {

const char* type_name(DataType t) {
  switch (t) {
    case DataType::kInt8: return "Int8";
    case DataType::kInt16: return "Int16";
    case DataType::kInt32: return "Int32";
    case DataType::kInt64: return "Int64";
    case DataType::kUInt8: return "UInt8";
    case DataType::kUInt16: return "UInt16";
    case DataType::kUInt32: return "UInt32";
    case DataType::kUInt64: return "UInt64";
    case DataType::kFloat: return "Float";
    case DataType::kDouble: return "Double";
    case DataType::kBoolean: return "Boolean";
    case DataType::kString: return "String";
    case DataType::kDateTime: return "DateTime";
    case DataType::kText: return "Text";
  }
  return "?";
}

TEST(MqttDoc, MetricTableMatchesTheCatalogue) {
  const auto path = std::filesystem::path(__FILE__).parent_path() / "../../../../docs/mqtt.md";
  std::ifstream in(path);
  ASSERT_TRUE(in.good()) << path;
  // | 1 | `Position` | Int64 | ...
  const std::regex row(R"(^\| (\d+) \| `([^`]+)` \| ([A-Za-z0-9]+) \|)");
  std::map<int, std::pair<std::string, std::string>> doc;
  std::string line;
  std::smatch m;
  while (std::getline(in, line))
    if (std::regex_search(line, m, row)) doc[std::stoi(m[1])] = {m[2], m[3]};
  std::size_t n = 0;
  for (const auto defs : {process_metrics(), command_metrics(), identity_metrics()}) {
    for (const MetricDef& d : defs) {
      ++n;
      const auto it = doc.find(static_cast<int>(d.id));
      ASSERT_NE(it, doc.end()) << d.name << " is not in docs/mqtt.md";
      EXPECT_EQ(it->second.first, d.name);
      EXPECT_EQ(it->second.second, type_name(d.type)) << d.name;
    }
  }
  EXPECT_EQ(doc.size(), n) << "docs/mqtt.md lists metrics the plugin does not have";
}

}  // namespace
}  // namespace cobridge::mqtt
