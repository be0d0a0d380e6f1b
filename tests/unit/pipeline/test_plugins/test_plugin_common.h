/* What the ABI-layout test plugins (test_old_abi, test_abi4, test_new_abi)
 * do alike: count their calls in test_plugin_record and hand their table
 * over. Each such file then holds only its own table's layout. One plugin
 * per library, so the record is defined here. */
#ifndef COBRIDGE_TEST_PLUGIN_COMMON_H
#define COBRIDGE_TEST_PLUGIN_COMMON_H

#include "test_plugin_record.h"

COBRIDGE_PLUGIN_EXPORT test_record test_plugin_record;

static int test_self;

static inline int test_start(void* self) {
  (void)self;
  ++test_plugin_record.started;
  return 0;
}
static inline void test_stop(void* self) {
  (void)self;
  ++test_plugin_record.stopped;
}
static inline void test_destroy(void* self) {
  (void)self;
  ++test_plugin_record.destroyed;
}

/* cobridge_plugin_create's work: counts it, hands over `table` (an older or
 * newer layout, as the caller spells it) and the instance. */
static inline int test_hand_over(const void* table, const cobridge_plugin_ops** ops_out, void** self_out) {
  ++test_plugin_record.created;
  *ops_out = (const cobridge_plugin_ops*)table;
  *self_out = &test_self;
  return 0;
}

#define TEST_PLUGIN_CREATE(table_ptr)                                                                      \
  COBRIDGE_PLUGIN_EXPORT int cobridge_plugin_create(const cobridge_host_api* host, const char* config_toml, \
                                                    size_t config_len, const cobridge_plugin_ops** ops_out, \
                                                    void** self_out, char* err, size_t err_len) {           \
    (void)host;                                                                                            \
    (void)config_toml;                                                                                     \
    (void)config_len;                                                                                      \
    (void)err;                                                                                             \
    (void)err_len;                                                                                         \
    return test_hand_over((table_ptr), ops_out, self_out);                                                 \
  }

#endif
