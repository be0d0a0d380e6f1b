/* A plugin built for ABI 4, whose ops table ended at on_role. The layout is
 * spelled out as the ABI 4 header had it. Right behind the table sits a trap
 * where an ABI 5 table has on_bus: a host that ignored struct_size would
 * call it and the test would see it. */
#include "test_plugin_common.h"

#include <stddef.h>

/* cobridge_plugin_ops as of ABI 4. */
typedef struct ops_v4 {
  uint32_t abi_version;
  uint32_t struct_size;
  const char* name;
  int (*start)(void* self);
  void (*stop)(void* self);
  void (*destroy)(void* self);
  void (*on_samples)(void* self, const cobridge_sample* samples, size_t count);
  void (*on_device)(void* self, const cobridge_device_info* info);
  size_t (*stats)(void* self, cobridge_stat* out, size_t max);
  void (*on_role)(void* self, const cobridge_role_info* info);
} ops_v4;

typedef struct ops_v4_with_trap {
  ops_v4 ops;
  void (*trap)(void* self, const cobridge_bus_info* info);
} ops_v4_with_trap;

_Static_assert(offsetof(ops_v4_with_trap, trap) == offsetof(cobridge_plugin_ops, on_bus),
               "the trap must sit exactly where an ABI 5 host looks for on_bus");

static void v4_on_samples(void* self, const cobridge_sample* samples, size_t count) {
  (void)self;
  (void)samples;
  test_plugin_record.samples_seen += count;
}
static void v4_trap(void* self, const cobridge_bus_info* info) {
  (void)self;
  (void)info;
  ++test_plugin_record.trap_calls;
}

static const ops_v4_with_trap table = {
    {4u, sizeof(ops_v4), "test_abi4", test_start, test_stop, test_destroy, v4_on_samples, NULL, NULL, NULL},
    v4_trap,
};

TEST_PLUGIN_CREATE(&table.ops)
