// The [control] and [ascii_gateway] sections (config/remote_access.hpp).
// Thread contract: the loader's calling thread.
#pragma once

#include "config/remote_access.hpp"
#include "config/table_reader.hpp"

namespace cobridge::config {

// Reads both sections from the top-level table into `out`; every problem goes to `sink`.
void read_remote_access(TableReader& top, DiagnosticSink& sink, RemoteAccess& out);

}  // namespace cobridge::config
