/* What a test plugin saw, exported as the symbol TEST_PLUGIN_RECORD so that
 * plugin_host_test can dlopen the same library and read it. Plain C: the
 * test plugins are written in C to prove that plugin.h is usable from C. */
#ifndef COBRIDGE_TEST_PLUGIN_RECORD_H
#define COBRIDGE_TEST_PLUGIN_RECORD_H

#include <cobridge/plugin.h>

#define TEST_PLUGIN_RECORD "test_plugin_record"

typedef struct test_plugin_record {
  int created;
  int started;
  int stopped;
  int destroyed;
  int on_samples_calls;
  int on_device_calls;
  /* Incremented by an op the host must never call (beyond struct_size). */
  int trap_calls;
  int stats_calls;
  unsigned long samples_seen;
  long long position_sum;
  cobridge_sample last_sample;
  unsigned host_abi_version;
  char gateway_id[64];
  char config[128];
  char last_device_name[64];
  /* ABI 4 */
  unsigned host_redundancy_node;
  int on_role_calls;
  int last_role;
  int last_role_master;
  char last_role_cause[64];
  /* ABI 5 */
  int on_bus_calls;
  int last_bus_state;
  int last_bus_tx_errors;
  unsigned long long last_bus_restarts;
  char last_bus_name[64];
} test_record;

#endif
