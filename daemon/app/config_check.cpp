#include "app/config_check.hpp"

#include "app/validation.hpp"
#include "outputs/output_pipeline.hpp"
#include "web/web_server.hpp"

#include <cstdio>

namespace cobridge::app {

int check_config(const std::filesystem::path& file, const std::filesystem::path& plugin_dir) {
  Validated v = validate(file);
  if (v.config) {
    // What the daemon would refuse at start: an output it cannot load or
    // whose settings the plugin rejects.
    v.errors = outputs::check_outputs(*v.config, plugin_dir);
    if (v.config->web) {
      for (auto& e : web::check_web_settings(*v.config->web)) v.errors.push_back(std::move(e));
    }
    if (!v.errors.empty()) v.config.reset();
  }
  print(v, stderr);
  if (!v.config) {
    std::fprintf(stderr, "%s: %zu error%s\n", file.c_str(), v.errors.size(), v.errors.size() == 1 ? "" : "s");
    return 1;
  }
  std::printf("%s: ok (%zu bus%s, %zu device%s, %zu output%s, %zu device description%s%s)\n", file.c_str(),
              v.config->buses.size(), v.config->buses.size() == 1 ? "" : "es", v.config->devices.size(),
              v.config->devices.size() == 1 ? "" : "s", v.config->outputs.size(),
              v.config->outputs.size() == 1 ? "" : "s", v.catalog->size(), v.catalog->size() == 1 ? "" : "s",
              v.config->web && v.config->web->enabled ? ", web" : "");
  return 0;
}

}  // namespace cobridge::app
