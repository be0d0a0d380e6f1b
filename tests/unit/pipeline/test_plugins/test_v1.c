/* A well-behaved plugin built against the current ABI (v1), in C. It records
 * every call in test_plugin_record and logs start/stop through the host so
 * that the test can see the order in which instances are stopped. */
#include "test_plugin_record.h"

#include <stdlib.h>
#include <string.h>

COBRIDGE_PLUGIN_EXPORT test_record test_plugin_record;

typedef struct instance {
  const cobridge_host_api* host;
} instance;

static void copy_str(char* dst, size_t dst_len, const char* src, size_t src_len) {
  size_t n = src_len < dst_len - 1 ? src_len : dst_len - 1;
  memcpy(dst, src, n);
  dst[n] = '\0';
}

static int v1_start(void* self) {
  instance* in = (instance*)self;
  ++test_plugin_record.started;
  in->host->log(in->host->host, COBRIDGE_LOG_INFO, "start");
  return 0;
}

static void v1_stop(void* self) {
  instance* in = (instance*)self;
  ++test_plugin_record.stopped;
  in->host->log(in->host->host, COBRIDGE_LOG_INFO, "stop");
}

static void v1_destroy(void* self) {
  ++test_plugin_record.destroyed;
  free(self);
}

static void v1_on_samples(void* self, const cobridge_sample* samples, size_t count) {
  size_t i;
  (void)self;
  ++test_plugin_record.on_samples_calls;
  for (i = 0; i < count; ++i) {
    test_plugin_record.samples_seen++;
    if ((samples[i].valid & COBRIDGE_VALID_POSITION) != 0) test_plugin_record.position_sum += samples[i].position;
    test_plugin_record.last_sample = samples[i];
  }
}

static void v1_on_device(void* self, const cobridge_device_info* info) {
  (void)self;
  ++test_plugin_record.on_device_calls;
  copy_str(test_plugin_record.last_device_name, sizeof test_plugin_record.last_device_name, info->name,
           strlen(info->name));
}

/* ABI 3: two well-formed figures, and one whose name cannot be a metric
 * name (the host must leave it out). */
static size_t v1_stats(void* self, cobridge_stat* out, size_t max) {
  const cobridge_stat figures[3] = {
      {"test_samples_seen", "Samples this instance saw.", COBRIDGE_STAT_COUNTER, 0, test_plugin_record.samples_seen},
      {"Bad-Name", "not a metric name", COBRIDGE_STAT_GAUGE, 0, 1},
      {"test_level", "A level.", COBRIDGE_STAT_GAUGE, 0, 7},
  };
  size_t i;
  (void)self;
  ++test_plugin_record.stats_calls;
  for (i = 0; i < 3 && i < max; ++i) out[i] = figures[i];
  return i;
}

/* ABI 4: the gateway's role on a bus. */
static void v1_on_role(void* self, const cobridge_role_info* info) {
  (void)self;
  ++test_plugin_record.on_role_calls;
  test_plugin_record.last_role = info->role;
  test_plugin_record.last_role_master = info->master_node;
  copy_str(test_plugin_record.last_role_cause, sizeof test_plugin_record.last_role_cause, info->cause,
           strlen(info->cause));
}

/* ABI 5: a bus's health. */
static void v1_on_bus(void* self, const cobridge_bus_info* info) {
  (void)self;
  ++test_plugin_record.on_bus_calls;
  test_plugin_record.last_bus_state = info->state;
  test_plugin_record.last_bus_tx_errors = info->tx_errors;
  test_plugin_record.last_bus_restarts = info->restarts;
  copy_str(test_plugin_record.last_bus_name, sizeof test_plugin_record.last_bus_name, info->bus_name,
           strlen(info->bus_name));
}

static const cobridge_plugin_ops ops = {
    COBRIDGE_PLUGIN_ABI_VERSION, sizeof(cobridge_plugin_ops), "test_v1", v1_start, v1_stop, v1_destroy,
    v1_on_samples, v1_on_device, v1_stats, v1_on_role, v1_on_bus,
};

int cobridge_plugin_create(const cobridge_host_api* host, const char* config_toml, size_t config_len,
                           const cobridge_plugin_ops** ops_out, void** self_out, char* err, size_t err_len) {
  instance* in = (instance*)malloc(sizeof(instance));
  (void)err;
  (void)err_len;
  if (in == NULL) return -1;
  in->host = host;
  ++test_plugin_record.created;
  test_plugin_record.host_abi_version = host->abi_version;
  test_plugin_record.host_redundancy_node = host->redundancy_node;
  copy_str(test_plugin_record.gateway_id, sizeof test_plugin_record.gateway_id, host->gateway_id,
           strlen(host->gateway_id));
  copy_str(test_plugin_record.config, sizeof test_plugin_record.config, config_toml, config_len);
  *ops_out = &ops;
  *self_out = in;
  return 0;
}
