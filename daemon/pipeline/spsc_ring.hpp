// The hot path's SPSC ring is the plugin SDK's (<cobridge/spsc_ring.hpp>):
// one implementation for the daemon and the plugins, named here as the
// pipeline layer has always named it.
//
// Threads: see <cobridge/spsc_ring.hpp>.
#pragma once

#include <cobridge/spsc_ring.hpp>

namespace cobridge::pipeline {

using cobridge::kCacheLine;
using cobridge::SpscRing;

}  // namespace cobridge::pipeline
