// `cobridge nmt COMMAND NODE|all`: one NMT command frame (CiA 301 §7.2.8.3.1).
#pragma once

#include <string>

namespace cobridge::cli {

struct NmtOptions {
  std::string iface;
  std::string command;  // start | stop | preop | reset | reset-comm
  std::string node;     // 1..127 or "all"
};

int nmt_send(const NmtOptions& o);

}  // namespace cobridge::cli
