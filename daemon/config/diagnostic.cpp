#include "config/diagnostic.hpp"

namespace cobridge::config {

std::string to_string(const Diagnostic& d) {
  std::string out = d.file;
  if (d.line != 0) {
    out += ':';
    out += std::to_string(d.line);
    out += ':';
    out += std::to_string(d.column);
  }
  out += ": ";
  out += d.message;
  return out;
}

}  // namespace cobridge::config
