// [gateway]: the gateway's id, state and device directories, control socket.
#include "config/loader.hpp"

#include "sys/install_paths.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <map>
#include <system_error>

namespace cobridge::config::detail {

// ---- [gateway] ---------------------------------------------------------

void Loader::read_gateway(TableReader& top) {
  auto& g = config_.gateway;
  g.id = host_name();
  g.state_dir = "/var/lib/cobridge";
  // The installed descriptions (<prefix>/share/cobridge/devices beside the
  // running executable) come first, when there are any: a build tree has none.
  g.device_dirs.clear();
  if (fs::path installed = sys::installed_or(sys::InstallDir::devices, {}); !installed.empty())
    g.device_dirs.push_back(std::move(installed));
  g.control_socket = "/run/cobridge/control.sock";
  const toml::table* t = top.subtable("gateway");
  if (t == nullptr) return;
  TableReader r(*t, "[gateway]", "", "gateway.", sink_);
  r.check_keys({"id", "state_dir", "device_dirs", "control_socket"});
  if (auto id = r.string("id")) {
    if (is_identifier(*id)) {
      g.id = *id;
    } else {
      r.error(*r.find("id"), "gateway.id " + in_quotes(*id) + " is not allowed (allowed: 1 to 64 of A-Z a-z 0-9 _ - .)");
    }
  }
  if (auto p = absolute_path(r, "state_dir")) g.state_dir = *p;
  if (auto p = absolute_path(r, "control_socket")) {
    // sockaddr_un::sun_path holds 108 bytes with its NUL (unix(7)).
    if (p->string().size() >= 108) {
      r.error(*r.find("control_socket"), "control_socket is " + std::to_string(p->string().size()) +
                                             " bytes long; a Unix socket path may have at most 107");
    } else {
      g.control_socket = *p;
    }
  }
  if (const toml::array* dirs = r.array("device_dirs")) {
    for (const toml::node& e : *dirs) {
      const auto* s = e.as_string();
      if (s == nullptr) {
        r.wrong_type(e, "gateway.device_dirs entry", "a string");
        continue;
      }
      const fs::path dir = resolve(s->get());
      std::error_code ec;
      if (!fs::is_directory(dir, ec)) {
        r.error(e, "gateway.device_dirs entry " + in_quotes(dir.string()) + " is not a directory");
        continue;
      }
      // The installed directory named again (or one directory twice) is one
      // set of files: loading it twice would call each file a duplicate of itself.
      const bool listed = std::any_of(g.device_dirs.begin(), g.device_dirs.end(), [&](const fs::path& d) {
        std::error_code eq;
        return fs::equivalent(d, dir, eq);
      });
      if (!listed) g.device_dirs.push_back(dir);
    }
  }
}

}  // namespace cobridge::config::detail
