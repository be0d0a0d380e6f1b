#include "sys/install_paths.hpp"

#include <system_error>

#ifndef COBRIDGE_INSTALL_PREFIX
#error "COBRIDGE_INSTALL_* come from daemon/sys/CMakeLists.txt"
#endif

namespace cobridge::sys {
namespace fs = std::filesystem;

fs::path executable() {
  std::error_code ec;
  fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path() : exe;
}

fs::path installed_dir(InstallDir which, const fs::path& exe) {
  const char* rel = COBRIDGE_INSTALL_DEVICE_DIR;
  if (which == InstallDir::plugins) rel = COBRIDGE_INSTALL_PLUGIN_DIR;
  if (which == InstallDir::idl) rel = COBRIDGE_INSTALL_IDL_DIR;
  const fs::path bindir(COBRIDGE_INSTALL_BINDIR);
  if (bindir.is_absolute() || exe.empty() || !exe.has_parent_path())
    return fs::path(COBRIDGE_INSTALL_PREFIX) / rel;
  // <prefix>/<bindir>/<name>: one level up per component of bindir.
  fs::path prefix = exe.parent_path();
  for (const auto& part : bindir) {
    if (part.empty() || part == ".") continue;
    prefix = prefix.parent_path();
  }
  return prefix / rel;
}

fs::path installed_or(InstallDir which, const fs::path& build_tree, const fs::path& exe) {
  fs::path dir = installed_dir(which, exe);
  std::error_code ec;
  if (fs::is_directory(dir, ec)) return dir;
  return build_tree;
}

}  // namespace cobridge::sys
