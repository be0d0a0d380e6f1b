// Validation of a configuration file as the daemon needs it: the config
// layer's checks, then the device descriptions every device needs (the part
// the config layer cannot do: it links no device layer).
//
// Thread: the main thread (start-up, --check-config and SIGHUP reload); file
// I/O and allocation, no shared state.
#pragma once

#include "base/error.hpp"
#include "config/config.hpp"
#include "device/device_catalog.hpp"

#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace cobridge::app {

struct Validated {
  std::optional<config::Config> config;  // set only when `errors` is empty
  std::unique_ptr<device::DeviceCatalog> catalog;
  std::vector<Error> errors;  // where = "file:line:column", in file order
  std::vector<std::string> warnings;
};

[[nodiscard]] Validated validate(const std::filesystem::path& file);

// The warnings ("warning: ...") then the errors ("where: message"), one a line.
void print(const Validated& v, std::FILE* to);

}  // namespace cobridge::app
