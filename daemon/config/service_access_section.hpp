// The [control] and [ascii_gateway] sections (config/service_access.hpp).
// Thread contract: the loader's calling thread.
#pragma once

#include "config/service_access.hpp"
#include "config/table_reader.hpp"

namespace cobridge::config {

// Reads both sections from the top-level table into `out`; every problem goes to `sink`.
void read_service_access(TableReader& top, DiagnosticSink& sink, ServiceAccess& out);

}  // namespace cobridge::config
