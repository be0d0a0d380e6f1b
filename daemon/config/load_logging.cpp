// [logging]: the log level, per-module levels and the log target.
#include "config/loader.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <map>
#include <system_error>

namespace cobridge::config::detail {

// ---- [logging] ---------------------------------------------------------

void Loader::read_logging(TableReader& top) {
  auto& l = config_.logging;
  const toml::table* t = top.subtable("logging");
  if (t == nullptr) return;
  TableReader r(*t, "[logging]", "", "logging.", sink_);
  r.check_keys({"level", "target", "modules"});
  if (auto v = r.choice<LogLevel>("level", kLevels)) l.level = *v;
  if (auto v = r.choice<LogTarget>(
          "target", {{"auto", LogTarget::automatic}, {"console", LogTarget::console}, {"journal", LogTarget::journal}})) {
    l.target = *v;
  }
  const toml::table* m = r.subtable("modules");
  if (m == nullptr) return;
  TableReader mr(*m, "[logging.modules]", "", "logging.modules.", sink_);
  mr.check_keys({kModules[0], kModules[1], kModules[2], kModules[3], kModules[4], kModules[5], kModules[6]});
  // Walk in file order so later use (and messages) follow the file.
  std::vector<std::pair<toml::source_position, std::string>> present;
  for (auto&& [key, value] : *m) {
    if (std::find(kModules.begin(), kModules.end(), key.str()) != kModules.end()) {
      present.emplace_back(value.source().begin, std::string(key.str()));
    }
  }
  std::sort(present.begin(), present.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [pos, module] : present) {
    if (auto v = mr.choice<LogLevel>(module, kLevels)) l.modules.emplace_back(module, *v);
  }
}

}  // namespace cobridge::config::detail
