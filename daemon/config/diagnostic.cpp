#include "config/diagnostic.hpp"

#include "config/config.hpp"

namespace cobridge::config {

std::string SourceLocation::to_string() const {
  if (line == 0) return file;
  return file + ':' + std::to_string(line) + ':' + std::to_string(column);
}

std::string to_string(const Diagnostic& d) { return to_error(d).to_string(); }

Error to_error(const Diagnostic& d) {
  return Error(Errc::kInvalidArgument, d.message, SourceLocation{d.file, d.line, d.column}.to_string());
}

}  // namespace cobridge::config
