// Allocation counter for the benchmarks' "heap allocations per frame"
// figures: malloc, calloc and realloc are interposed for the whole process
// (every thread, plugins and libraries included) and counted between
// start and stop. Linking this file into a bench is what interposes them.
#pragma once

namespace cobridge::bench {

void start_counting_allocations() noexcept;
// Allocations since start_counting_allocations().
unsigned long long stop_counting_allocations() noexcept;

// The same, for the calling thread only: the allocations other threads make
// meanwhile (a web server, its clients) are not counted. For the benches that
// prove a service running beside the hot path adds nothing to it.
void start_counting_this_thread() noexcept;
unsigned long long stop_counting_this_thread() noexcept;

}  // namespace cobridge::bench
