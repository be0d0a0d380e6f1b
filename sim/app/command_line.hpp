// CommandLine: cobridge-sim's arguments.
//
//   cobridge-sim --iface vcan0 --device MODEL[:key=value,...] [--device ...]
//                [--iface vcan1 --device ...] [--state-dir DIR] [--truth FILE]
//                [--control PATH] [--devices-dir DIR]
//
// A --device belongs to the --iface before it. Parsing is CLI11; errors name
// the argument and what it allows and end the program with exit code 2.
// Thread: start-up only.
#pragma once

#include "app/device_argument.hpp"

#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace cobridge::sim {

struct BusOptions {
  std::string iface;
  std::vector<DeviceSpec> devices;  // serials assigned (unique across all buses)
};

struct SimOptions {
  std::vector<BusOptions> buses;
  std::filesystem::path state_dir;    // empty: volatile non-volatile memory
  std::filesystem::path truth_file;   // empty: none
  std::filesystem::path control_path; // empty: stdin only
  std::filesystem::path devices_dir;  // resolved (installed dir or source tree)
  int rt_priority = 0;                // SCHED_FIFO priority of the loop thread; 0: the normal scheduler
};

// What the command line asks for: a run with `options`, the help text, or
// nothing because it is wrong (`error`, kInvalidArgument).
struct CommandLineResult {
  SimOptions options;
  std::string help;  // --help: the text for stdout
  Error error;       // a bad command line

  // -1: run; 0: print the help; else exit_code(error.kind) (2).
  [[nodiscard]] int exit_code() const noexcept;
  // The help text, or "cobridge-sim: <error>", for the caller to print.
  [[nodiscard]] std::string output() const;
};

// `lookup` resolves MODEL (sim::find_model), `models` lists them in --help
// (sim::all_models()). `installed_devices_dir` and `source_devices_dir` are the two defaults of
// --devices-dir, tried in that order (the first that exists wins).
[[nodiscard]] CommandLineResult parse_command_line(int argc, const char* const* argv, ModelLookup lookup,
                                                   std::span<const ModelInfo> models,
                                                   const std::filesystem::path& installed_devices_dir,
                                                   const std::filesystem::path& source_devices_dir);

}  // namespace cobridge::sim
