// PluginTrust: whether a plugin file may be loaded into the daemon.
// A plugin runs with all of the service's rights, on its hot path,
// so the file, and the directory it is in, must be as trusted as the daemon
// itself: owned by root (or by the user the daemon runs as, for a developer's
// own build) and writable by nobody else. Checked with stat() before dlopen,
// so no code of a refused file ever runs, not even under --check-config.
//
// Thread: the control thread (plugin loading); file-system reads only.
#pragma once

#include "base/error.hpp"

#include <sys/types.h>

#include <filesystem>
#include <string>

namespace cobridge::pipeline {

// kOk when `file` may be loaded; else (kPermissionDenied) why not ("owned by
// uid 1000, not root or the daemon's user (uid 0)", "writable by group or
// others (mode 0775)", ...). `daemon_uid`: the daemon's effective uid.
[[nodiscard]] Error plugin_distrust(const std::filesystem::path& file, uid_t daemon_uid);

}  // namespace cobridge::pipeline
