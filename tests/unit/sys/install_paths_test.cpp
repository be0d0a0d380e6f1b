// Install paths: data directories found from the executable, so
// `cmake --install --prefix X` anywhere (and the Debian package) work.
#include "sys/install_paths.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>

using namespace cobridge::sys;
namespace fs = std::filesystem;

TEST(InstallPaths, RelativeToThePrefixOfTheExecutable) {
  EXPECT_EQ(installed_dir(InstallDir::devices, "/opt/cobridge/bin/cobridged"), "/opt/cobridge/share/cobridge/devices");
  EXPECT_EQ(installed_dir(InstallDir::idl, "/opt/cobridge/bin/cobridge"), "/opt/cobridge/share/cobridge/idl");
  // libdir may be lib or lib/<multiarch>: under the prefix either way.
  const fs::path plugins = installed_dir(InstallDir::plugins, "/usr/bin/cobridged");
  EXPECT_EQ(plugins.filename(), "plugins");
  EXPECT_EQ(plugins.parent_path().filename(), "cobridge");
  EXPECT_EQ(*plugins.begin(), "/");
  EXPECT_EQ(*std::next(plugins.begin()), "usr");
  EXPECT_EQ(*std::next(plugins.begin(), 2), "lib");
}

TEST(InstallPaths, ExecutableIsThisProcess) {
  const fs::path exe = executable();
  ASSERT_FALSE(exe.empty());
  EXPECT_TRUE(exe.is_absolute());
  EXPECT_TRUE(fs::equivalent(exe, "/proc/self/exe"));
}

TEST(InstallPaths, InstalledTreeWinsOverTheBuildTree) {
  const fs::path root = fs::temp_directory_path() / ("cobridge-install-paths-" + std::to_string(::getpid()));
  fs::remove_all(root);
  const fs::path exe = root / "prefix" / "bin" / "cobridged";
  fs::create_directories(exe.parent_path());
  std::ofstream(exe) << "";
  const fs::path build = root / "build-devices";
  fs::create_directories(build);

  // No share/cobridge/devices beside bin/: the build tree's.
  EXPECT_EQ(installed_or(InstallDir::devices, build, exe), build);
  fs::create_directories(root / "prefix" / "share" / "cobridge" / "devices");
  EXPECT_EQ(installed_or(InstallDir::devices, build, exe), root / "prefix" / "share" / "cobridge" / "devices");
  // A moved tree follows its executable.
  fs::rename(root / "prefix", root / "moved");
  EXPECT_EQ(installed_or(InstallDir::devices, build, root / "moved" / "bin" / "cobridged"),
            root / "moved" / "share" / "cobridge" / "devices");
  // A file where the directory should be is not a directory.
  EXPECT_EQ(installed_or(InstallDir::plugins, build, exe), build);
  fs::remove_all(root);
}
