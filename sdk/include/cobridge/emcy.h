/* The meaning of a CANopen EMCY (CiA 301 §7.2.7) for an output plugin.
 *
 * The daemon hands plugins EMCY samples as raw bytes (cobridge_sample:
 * emcy_code, emcy_register, emcy_data). These functions give the text the
 * device family's manual assigns to them, from the same tables the daemon logs
 * with (each family's module in daemon/families, the CiA 301 table of
 * daemon/canopen/emcy.cpp, combined by daemon/device/emcy_meaning.cpp; all
 * compiled into libcobridge_sdk, there is no second copy).
 *
 * Thread: any. cobridge_emcy_classify() is allocation-free and returns static
 * text, so it may run on a plugin's publishing thread. cobridge_emcy_describe()
 * allocates inside and belongs off the hot path. */
#ifndef COBRIDGE_EMCY_H
#define COBRIDGE_EMCY_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* E§9.1 "Level" (Novotechnik multiturn); the other manuals define none. */
enum cobridge_emcy_level {
  COBRIDGE_EMCY_LEVEL_UNSPECIFIED = 0,
  COBRIDGE_EMCY_LEVEL_INFO = 1,
  COBRIDGE_EMCY_LEVEL_WARN = 2,
  COBRIDGE_EMCY_LEVEL_ERROR = 3,
  COBRIDGE_EMCY_LEVEL_HARD = 4
};

/* Text fields point to static storage and are not NUL-terminated: use the
 * lengths. */
typedef struct cobridge_emcy_info {
  const char* text;   /* the manual's meaning, else the CiA 301 text */
  size_t text_len;
  const char* source; /* "J§1.8.1", "E§9.1" or "CiA 301" */
  size_t source_len;
  int level;          /* enum cobridge_emcy_level */
  int from_manual;    /* 1: a row of the family's own table matched */
  int error_reset;    /* 1: announces that the error condition is gone */
} cobridge_emcy_info;

/* `family` is cobridge_device_info.family ("novotechnik-rotary",
 * "novotechnik-multiturn", "ifm-rm", also with '_'); NULL or anything else
 * gives the CiA 301 texts only. `manufacturer` is the 5 bytes 3..7 of the
 * frame (cobridge_sample.emcy_data); NULL reads as zeros. Returns 0, or -1
 * when `out` is NULL. */
int cobridge_emcy_classify(const char* family, uint16_t error_code, uint8_t error_register,
                           const uint8_t* manufacturer, cobridge_emcy_info* out);

/* One log line (code, meaning, source, level, decoded detail bytes) into
 * `buf`, truncated to fit and NUL-terminated. Returns the full length
 * (like snprintf). Allocates; not for the hot path. */
size_t cobridge_emcy_describe(const char* family, uint16_t error_code, uint8_t error_register,
                              const uint8_t* manufacturer, char* buf, size_t buf_len);

#ifdef __cplusplus
}
#endif

#endif /* COBRIDGE_EMCY_H */
