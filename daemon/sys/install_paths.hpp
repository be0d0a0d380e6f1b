// Install paths: where an installed cobridge keeps its data files, found from
// the running executable rather than from the prefix it was configured with.
// `cmake --install --prefix X` (or a tree moved elsewhere, or the Debian
// package under /usr) lays out X/<bindir>/cobridged beside
// X/<datadir>/cobridge/devices and X/<libdir>/cobridge/plugins; the relative
// layout is compiled in (GNUInstallDirs), the prefix is read from
// /proc/self/exe. The build tree keeps the plugins in the same place
// relative to build/daemon/cobridged (build/lib/cobridge/plugins), so the
// daemon needs no fallback and has none compiled in; the
// data directories may name a build-tree fallback (installed_or).
//
// Thread: any; reads /proc/self/exe and stats directories, no state.
#pragma once

#include <filesystem>

namespace cobridge::sys {

enum class InstallDir {
  devices,  // <datadir>/cobridge/devices: EDS files
  plugins,  // <libdir>/cobridge/plugins: output plugins
  idl,      // <datadir>/cobridge/idl: cobridge.idl for DDS subscribers
};

// The running executable, symlinks resolved; empty when /proc is unreadable.
[[nodiscard]] std::filesystem::path executable();

// The directory `which` of the installed tree that holds `exe` (pure: no
// file system access). With an absolute CMAKE_INSTALL_BINDIR the prefix
// cannot be derived from the executable and the configured one is used.
[[nodiscard]] std::filesystem::path installed_dir(InstallDir which, const std::filesystem::path& exe);

// installed_dir(which, exe) when that directory exists, else build_tree
// (running from a build tree, or from an install without that folder).
[[nodiscard]] std::filesystem::path installed_or(InstallDir which, const std::filesystem::path& build_tree,
                                                 const std::filesystem::path& exe = executable());

}  // namespace cobridge::sys
