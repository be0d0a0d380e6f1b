/* A plugin that misbehaves the way its configuration text says:
 *   create_fails  create returns non-zero with a message
 *   null_ops      create returns 0 but no ops table
 *   small_table   struct_size smaller than the mandatory ops
 *   missing_op    on_samples is NULL
 *   start_fails   start returns 7 */
#include "test_plugin_record.h"

#include <stdio.h>
#include <string.h>

COBRIDGE_PLUGIN_EXPORT test_record test_plugin_record;

static int dummy_self;

static int faulty_start(void* self) {
  (void)self;
  ++test_plugin_record.started;
  return 0;
}
static int faulty_start_fails(void* self) {
  (void)self;
  ++test_plugin_record.started;
  return 7;
}
static void faulty_stop(void* self) {
  (void)self;
  ++test_plugin_record.stopped;
}
static void faulty_destroy(void* self) {
  (void)self;
  ++test_plugin_record.destroyed;
}
static void faulty_on_samples(void* self, const cobridge_sample* samples, size_t count) {
  (void)self;
  (void)samples;
  (void)count;
  ++test_plugin_record.on_samples_calls;
}

static const cobridge_plugin_ops small_table = {
    COBRIDGE_PLUGIN_ABI_VERSION, 16u, "test_faulty", faulty_start, faulty_stop, faulty_destroy, faulty_on_samples,
    NULL, NULL, NULL, NULL,
};
static const cobridge_plugin_ops missing_op = {
    COBRIDGE_PLUGIN_ABI_VERSION, sizeof(cobridge_plugin_ops), "test_faulty", faulty_start, faulty_stop,
    faulty_destroy, NULL, NULL, NULL, NULL, NULL,
};
static const cobridge_plugin_ops start_fails = {
    COBRIDGE_PLUGIN_ABI_VERSION, sizeof(cobridge_plugin_ops), "test_faulty", faulty_start_fails, faulty_stop,
    faulty_destroy, faulty_on_samples, NULL, NULL, NULL, NULL,
};

static int is_mode(const char* config, size_t len, const char* mode) {
  return len == strlen(mode) && memcmp(config, mode, len) == 0;
}

int cobridge_plugin_create(const cobridge_host_api* host, const char* config_toml, size_t config_len,
                           const cobridge_plugin_ops** ops_out, void** self_out, char* err, size_t err_len) {
  (void)host;
  *self_out = &dummy_self;
  if (is_mode(config_toml, config_len, "create_fails")) {
    snprintf(err, err_len, "serial port /dev/ttyX4 does not exist");
    return 3;
  }
  ++test_plugin_record.created;
  if (is_mode(config_toml, config_len, "null_ops")) {
    *ops_out = NULL;
  } else if (is_mode(config_toml, config_len, "small_table")) {
    *ops_out = &small_table;
  } else if (is_mode(config_toml, config_len, "missing_op")) {
    *ops_out = &missing_op;
  } else {
    *ops_out = &start_fails;
  }
  return 0;
}
