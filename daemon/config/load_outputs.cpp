// [outputs.<name>]: the output plugins and their settings (kept as TOML for
// the plugin).
#include "config/loader.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <map>
#include <system_error>

namespace cobridge::config::detail {

// ---- [outputs.<name>] --------------------------------------------------

void Loader::read_outputs(TableReader& top) {
  const toml::table* outputs = top.subtable("outputs");
  if (outputs == nullptr) return;
  std::vector<const toml::key*> keys;
  for (auto&& [key, value] : *outputs) keys.push_back(&key);
  std::sort(keys.begin(), keys.end(),
            [](const toml::key* a, const toml::key* b) { return a->source().begin < b->source().begin; });
  for (const toml::key* key : keys) {
    const std::string name(key->str());
    const toml::node& value = *outputs->get(name);
    const auto* t = value.as_table();
    if (t == nullptr) {
      sink_.add(value.source().begin, "outputs." + name + " must be a table ([outputs." + name + "]), got " +
                                          std::string(type_name(value.type())));
      continue;
    }
    if (!is_identifier(name)) {
      sink_.add(key->source().begin,
                "output name " + in_quotes(name) + " is not allowed (allowed: 1 to 64 of A-Z a-z 0-9 _ - .)");
      continue;
    }
    TableReader r(*t, "[outputs." + name + "]", "", "outputs." + name + ".", sink_);
    Output out;
    out.name = name;
    out.where = location(sink_, *t);
    if (auto v = r.boolean("enabled")) out.enabled = *v;
    if (auto v = r.string("plugin")) {
      if (v->empty()) {
        r.error(*r.find("plugin"), r.path("plugin") + " must name a file, got \"\"");
      } else if (v->find('/') != std::string::npos || *v == "." || *v == "..") {
        // Plugins load from the plugin directory only (docs/plugins.md).
        r.error(*r.find("plugin"), r.path("plugin") + " " + in_quotes(*v) +
                                       " must be a file name in the plugin directory, not a path");
      } else {
        out.plugin = *v;
      }
    }
    toml::table rest = *t;
    rest.erase("enabled");
    rest.erase("plugin");
    std::ostringstream os;
    os << toml::toml_formatter{rest};
    out.settings_toml = os.str();
    config_.outputs.push_back(std::move(out));
  }
}

}  // namespace cobridge::config::detail
