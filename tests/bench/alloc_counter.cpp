#include "alloc_counter.hpp"

#include <atomic>
#include <cstddef>

extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void __libc_free(void*);
}

namespace {
std::atomic<bool> g_counting{false};
std::atomic<unsigned long long> g_allocs{0};
// Static TLS of the executable: reading it never allocates.
thread_local bool t_counting = false;
thread_local unsigned long long t_allocs = 0;
void count() noexcept {
  if (g_counting.load(std::memory_order_relaxed)) g_allocs.fetch_add(1, std::memory_order_relaxed);
  if (t_counting) ++t_allocs;
}
}  // namespace

extern "C" void* malloc(std::size_t n) {
  count();
  return __libc_malloc(n);
}
extern "C" void* calloc(std::size_t a, std::size_t b) {
  count();
  return __libc_calloc(a, b);
}
extern "C" void* realloc(void* p, std::size_t n) {
  count();
  return __libc_realloc(p, n);
}
extern "C" void free(void* p) { __libc_free(p); }

namespace cobridge::bench {

void start_counting_allocations() noexcept {
  g_allocs.store(0, std::memory_order_relaxed);
  g_counting.store(true, std::memory_order_release);
}

unsigned long long stop_counting_allocations() noexcept {
  g_counting.store(false, std::memory_order_release);
  return g_allocs.load(std::memory_order_relaxed);
}

void start_counting_this_thread() noexcept {
  t_allocs = 0;
  t_counting = true;
}

unsigned long long stop_counting_this_thread() noexcept {
  t_counting = false;
  return t_allocs;
}

}  // namespace cobridge::bench
