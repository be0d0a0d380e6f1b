#include "config/load.hpp"
#include "config/loader.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <system_error>

// The entry points: read the file, run one Loader, and turn any exception
// into a diagnostic (nothing here throws). The section readers are
// load_*.cpp (see loader.hpp).
namespace cobridge::config {
namespace {

namespace fs = std::filesystem;

LoadResult internal_error(std::string_view file, const char* what) noexcept {
  try {
    return LoadResult(std::vector<Diagnostic>{Diagnostic{std::string(file), 0, 0, std::string("internal error: ") + what}});
  } catch (...) {
    return LoadResult(std::vector<Diagnostic>{});
  }
}

}  // namespace

LoadResult load_string(std::string_view text, std::string_view file_name, const fs::path& base_dir) noexcept {
  try {
    detail::Loader loader(file_name, base_dir);
    return loader.run(text);
  } catch (const std::exception& e) {
    return internal_error(file_name, e.what());
  } catch (...) {
    return internal_error(file_name, "unknown exception");
  }
}

LoadResult load(const fs::path& path) noexcept {
  try {
    // An ifstream opens a directory and then reads nothing, which would
    // pass for an empty (valid) file.
    std::error_code ec;
    if (fs::is_directory(path, ec)) {
      return LoadResult(std::vector<Diagnostic>{
          Diagnostic{path.string(), 0, 0, "cannot read the configuration file: it is a directory"}});
    }
    std::ifstream in(path, std::ios::binary);
    if (!in) {
      const int err = errno;
      return LoadResult(std::vector<Diagnostic>{
          Diagnostic{path.string(), 0, 0, std::string("cannot open the configuration file: ") + std::strerror(err)}});
    }
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) {
      return LoadResult(std::vector<Diagnostic>{Diagnostic{path.string(), 0, 0, "cannot read the configuration file"}});
    }
    fs::path base = path.parent_path();
    if (base.empty()) base = ".";
    return load_string(text.str(), path.string(), base);
  } catch (const std::exception& e) {
    return internal_error(path.native(), e.what());
  } catch (...) {
    return internal_error(path.native(), "unknown exception");
  }
}

}  // namespace cobridge::config
