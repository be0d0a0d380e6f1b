/* A plugin built against a future ABI (host's version + 1) whose table has
 * one more op appended. The host must refuse it, free the instance through
 * destroy (same offset in every version) and never call anything else. */
#include "test_plugin_common.h"

typedef struct ops_next {
  cobridge_plugin_ops v1;
  void (*on_future)(void* self);
} ops_next;

static void next_on_samples(void* self, const cobridge_sample* samples, size_t count) {
  (void)self;
  (void)samples;
  (void)count;
  ++test_plugin_record.on_samples_calls;
}
static void next_on_device(void* self, const cobridge_device_info* info) {
  (void)self;
  (void)info;
  ++test_plugin_record.on_device_calls;
}
static void next_on_future(void* self) {
  (void)self;
  ++test_plugin_record.trap_calls;
}

static const ops_next table = {
    {COBRIDGE_PLUGIN_ABI_VERSION + 1u, sizeof(ops_next), "test_new_abi", test_start, test_stop, test_destroy,
     next_on_samples, next_on_device, NULL, NULL, NULL},
    next_on_future,
};

TEST_PLUGIN_CREATE(&table.v1)
