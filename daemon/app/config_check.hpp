// `cobridged --check-config FILE`: everything the daemon would refuse at
// start (configuration, device descriptions, outputs and their settings, the
// web settings), printed, without touching a bus.
//
// Thread: the main thread; nothing else runs.
#pragma once

#include <filesystem>

namespace cobridge::app {

// Prints the problems on stderr, or "FILE: ok (...)" on stdout; returns the
// exit status (0 or 1).
[[nodiscard]] int check_config(const std::filesystem::path& file, const std::filesystem::path& plugin_dir);

}  // namespace cobridge::app
