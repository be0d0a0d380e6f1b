/* emcylog: a minimal output plugin. It remembers each device's family
 * (on_device), gives every EMCY sample its meaning with the SDK's
 * cobridge_emcy_classify(), and reports how many it saw and the last one when
 * it stops. The per-sample path stays silent and allocation-free, as
 * cobridge/plugin.h asks: it only counts and copies into fixed buffers. */
#include <cobridge/emcy.h>
#include <cobridge/plugin.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_DEVICES 256
#define FAMILY_LEN 32

typedef struct emcylog {
  const cobridge_host_api* host;
  char family[MAX_DEVICES][FAMILY_LEN]; /* by device_index */
  unsigned long count;
  char last[200];
} emcylog;

static int el_start(void* self) {
  emcylog* p = (emcylog*)self;
  p->host->log(p->host->host, COBRIDGE_LOG_INFO, "emcylog: started");
  return 0;
}

static void el_stop(void* self) {
  emcylog* p = (emcylog*)self;
  char line[300];
  snprintf(line, sizeof line, "emcylog: %lu EMCY; last: %s", p->count, p->count ? p->last : "none");
  p->host->log(p->host->host, COBRIDGE_LOG_INFO, line);
}

static void el_destroy(void* self) { free(self); }

static void el_on_samples(void* self, const cobridge_sample* samples, size_t count) {
  emcylog* p = (emcylog*)self;
  size_t i;
  for (i = 0; i < count; ++i) {
    const cobridge_sample* s = &samples[i];
    cobridge_emcy_info info;
    if (s->kind != COBRIDGE_SAMPLE_EMCY || (s->valid & COBRIDGE_VALID_EMCY) == 0) continue;
    if (cobridge_emcy_classify(p->family[s->device_index % MAX_DEVICES], s->emcy_code, s->emcy_register,
                               s->emcy_data, &info) != 0)
      continue;
    ++p->count;
    snprintf(p->last, sizeof p->last, "node %u 0x%04X %.*s (%.*s)", (unsigned)s->node_id, (unsigned)s->emcy_code,
             (int)info.text_len, info.text, (int)info.source_len, info.source);
  }
}

static void el_on_device(void* self, const cobridge_device_info* info) {
  emcylog* p = (emcylog*)self;
  char* family = p->family[info->device_index % MAX_DEVICES];
  strncpy(family, info->family, FAMILY_LEN - 1);
  family[FAMILY_LEN - 1] = '\0';
}

static const cobridge_plugin_ops ops = {
    COBRIDGE_PLUGIN_ABI_VERSION, sizeof(cobridge_plugin_ops), "emcylog", el_start, el_stop, el_destroy,
    el_on_samples, el_on_device,
};

int cobridge_plugin_create(const cobridge_host_api* host, const char* config_toml, size_t config_len,
                           const cobridge_plugin_ops** ops_out, void** self_out, char* err, size_t err_len) {
  emcylog* p = (emcylog*)calloc(1, sizeof(emcylog));
  (void)config_toml;
  (void)config_len;
  if (p == NULL) {
    if (err != NULL && err_len > 0) snprintf(err, err_len, "emcylog: out of memory");
    return -1;
  }
  p->host = host;
  *ops_out = &ops;
  *self_out = p;
  return 0;
}
