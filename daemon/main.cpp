// cobridged: the gateway daemon. This file only reads the command line; the
// parts and their order live in app/daemon.hpp (configuration -> logging ->
// signals -> device catalog -> state store -> control socket -> outputs ->
// one BusManager per bus -> web service; stopped in reverse).
//
// Threads: main() runs the daemon's main loop (Daemon::serve); every part
// that needs a thread owns it. The signals are blocked before any thread
// starts and read through a signalfd, so nothing runs in a signal handler.
#include "app/config_check.hpp"
#include "app/daemon.hpp"
#include "app/hash_password_command.hpp"
#include "sys/install_paths.hpp"

#include <CLI/CLI.hpp>

#include <filesystem>
#include <string>

namespace {

// The plugin directory of this executable's install tree (<prefix>/lib/cobridge/plugins
// from <prefix>/<bindir>/cobridged; in the build tree build/lib/cobridge/plugins,
// the same layout). No compiled-in fallback path: an installed binary never
// loads plugins from a build tree.
std::filesystem::path default_plugin_dir() {
  return cobridge::sys::installed_dir(cobridge::sys::InstallDir::plugins, cobridge::sys::executable());
}

int run(cobridge::app::DaemonOptions options) {
  cobridge::app::Daemon daemon(std::move(options));  // before any thread: blocks the signals
  if (const cobridge::Error e = daemon.start()) return cobridge::exit_code(e.kind);
  daemon.serve();
  daemon.stop();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cobridged: discovers, commissions, configures and supervises CANopen encoders on SocketCAN buses"};
  std::string config_file = "/etc/cobridge/cobridge.toml";
  std::string check_file;
  std::string state_dir;
  bool foreground = false;
  app.add_option("-c,--config", config_file, "configuration file")->capture_default_str();
  app.add_option("--check-config", check_file,
                 "validate FILE (and the device descriptions it needs), print every problem, exit 0 or 1; "
                 "never opens a bus");
  bool hash_password = false;
  app.add_flag("--hash-password", hash_password,
               "read a password (twice from a terminal, else the first line of stdin) and print its yescrypt "
               "hash for web.auth_file's user:hash lines");
  app.add_flag("-f,--foreground", foreground, "log to the console (the default when not under systemd)");
  app.add_option("--state-dir", state_dir, "override gateway.state_dir");
  std::string plugin_dir;
  app.add_option("--plugin-dir", plugin_dir, "where the output plugins are (default: the installed plugin directory)");
  app.set_version_flag("--version", std::string("cobridged ") + COBRIDGE_VERSION);
  CLI11_PARSE(app, argc, argv);

  if (hash_password) return cobridge::app::hash_password_command(stdin, stdout, stderr);
  const std::filesystem::path plugins = plugin_dir.empty() ? default_plugin_dir() : std::filesystem::path(plugin_dir);
  if (!check_file.empty()) return cobridge::app::check_config(check_file, plugins);
  return run({config_file, foreground, state_dir, plugins, COBRIDGE_VERSION});
}
