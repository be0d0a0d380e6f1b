/* A plugin built against a future ABI (host's version + 1) whose table has
 * one more op appended. The host must refuse it, free the instance through
 * destroy (same offset in every version) and never call anything else. */
#include "test_plugin_record.h"

COBRIDGE_PLUGIN_EXPORT test_record test_plugin_record;

typedef struct ops_next {
  cobridge_plugin_ops v1;
  void (*on_future)(void* self);
} ops_next;

static int dummy_self;

static int next_start(void* self) {
  (void)self;
  ++test_plugin_record.started;
  return 0;
}
static void next_stop(void* self) {
  (void)self;
  ++test_plugin_record.stopped;
}
static void next_destroy(void* self) {
  (void)self;
  ++test_plugin_record.destroyed;
}
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
    {COBRIDGE_PLUGIN_ABI_VERSION + 1u, sizeof(ops_next), "test_new_abi", next_start, next_stop, next_destroy,
     next_on_samples, next_on_device, NULL, NULL, NULL},
    next_on_future,
};

int cobridge_plugin_create(const cobridge_host_api* host, const char* config_toml, size_t config_len,
                           const cobridge_plugin_ops** ops_out, void** self_out, char* err, size_t err_len) {
  (void)host;
  (void)config_toml;
  (void)config_len;
  (void)err;
  (void)err_len;
  ++test_plugin_record.created;
  *ops_out = &table.v1;
  *self_out = &dummy_self;
  return 0;
}
