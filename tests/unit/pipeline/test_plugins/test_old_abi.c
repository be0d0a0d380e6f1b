/* A plugin from before on_device existed: ABI version 0, whose ops table
 * ended at on_samples. The layout is spelled out here as that older header
 * had it. Right behind the table sits a trap where a v1 table has on_device:
 * a host that ignored struct_size would call it and the test would see it. */
#include "test_plugin_common.h"

#include <stddef.h>

/* cobridge_plugin_ops as of ABI 0. */
typedef struct ops_v0 {
  uint32_t abi_version;
  uint32_t struct_size;
  const char* name;
  int (*start)(void* self);
  void (*stop)(void* self);
  void (*destroy)(void* self);
  void (*on_samples)(void* self, const cobridge_sample* samples, size_t count);
} ops_v0;

typedef struct ops_v0_with_trap {
  ops_v0 ops;
  void (*trap)(void* self, const cobridge_device_info* info);
} ops_v0_with_trap;

_Static_assert(offsetof(ops_v0_with_trap, trap) == offsetof(cobridge_plugin_ops, on_device),
               "the trap must sit exactly where a v1 host would look for on_device");

static void v0_on_samples(void* self, const cobridge_sample* samples, size_t count) {
  size_t i;
  (void)self;
  ++test_plugin_record.on_samples_calls;
  for (i = 0; i < count; ++i) {
    test_plugin_record.samples_seen++;
    test_plugin_record.last_sample = samples[i];
  }
}
static void v0_trap(void* self, const cobridge_device_info* info) {
  (void)self;
  (void)info;
  ++test_plugin_record.trap_calls;
}

static const ops_v0_with_trap table = {
    {0u, sizeof(ops_v0), "test_old_abi", test_start, test_stop, test_destroy, v0_on_samples},
    v0_trap,
};

/* What an ABI-0 plugin hands over: a pointer to its (shorter) table. */
TEST_PLUGIN_CREATE(&table.ops)
