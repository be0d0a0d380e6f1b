/* cobridge output-plugin interface: the versioned C ABI between the gateway
 * daemon and its output plugins (DDS, Modbus, the JSON tap, your own).
 *
 * A plugin is a shared library that exports one C function,
 * cobridge_plugin_create (COBRIDGE_PLUGIN_ENTRY). The daemon dlopen()s the
 * library, looks the function up, and calls it once per configured instance
 * with the host API and the instance's configuration text. The plugin answers
 * with a table of operations (cobridge_plugin_ops) and an opaque instance
 * pointer that is passed back to every operation. The plugin may be written in
 * C++ inside, but nothing but C types cross this boundary, and no C++
 * exception may escape any function of the table or the entry point.
 *
 * Threads:
 *   - cobridge_plugin_create, start, stop, destroy: the daemon's control
 *     thread, never concurrently with each other or with the two below.
 *   - on_samples, on_device, on_role (ABI 4), on_bus (ABI 5): the
 *     dispatcher thread, between start and stop. They are the hot path: they must not block (no waiting on sockets,
 *     locks held by slow threads, or disk flushes per sample). A plugin with
 *     slow I/O copies the samples into its own queue and does the I/O on its
 *     own thread.
 *   - host->log: any thread of the plugin, but not on the per-sample path.
 *
 * Versioning (COBRIDGE_PLUGIN_ABI_VERSION): structures that carry a
 * struct_size only ever grow at their end. A newer daemon loads every plugin
 * built for the same or an older ABI; it reads the plugin's ops->struct_size
 * and never calls an operation that lies beyond it. A plugin reads
 * host->struct_size the same way before using a field of cobridge_host_api
 * added after the version it was built for. A plugin built for a newer ABI
 * than the daemon's is refused (it is destroyed and unloaded right away).
 * cobridge_sample is a fixed 128-byte value: new fields take space from its
 * reserved tail and get a new bit in `valid`, so its size never changes.
 */
#ifndef COBRIDGE_PLUGIN_H
#define COBRIDGE_PLUGIN_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* History: 1 = first release; 2 = commands (cobridge_host_api.submit_command,
 * COBRIDGE_SAMPLE_COMMAND and the command_* sample fields); 3 = the optional
 * stats operation (what the status page and /metrics show of an output);
 * 4 = hot standby (cobridge_host_api.redundancy_node, the optional on_role
 * operation and cobridge_role_info); 5 = bus health (the optional on_bus
 * operation and cobridge_bus_info); 6 = the configuration's state
 * (cobridge_device_info.config_state). */
#define COBRIDGE_PLUGIN_ABI_VERSION 6u

/* Name of the exported entry point, for dlsym(). */
#define COBRIDGE_PLUGIN_ENTRY "cobridge_plugin_create"

/* Plugins build with -fvisibility=hidden and mark only the entry point. */
#if defined(__GNUC__)
#define COBRIDGE_PLUGIN_EXPORT __attribute__((visibility("default")))
#else
#define COBRIDGE_PLUGIN_EXPORT
#endif

/* ------------------------------------------------------------------------ */
/* Samples                                                                  */

/* What a sample reports. Values are frozen; new kinds are only added. */
enum cobridge_sample_kind {
  COBRIDGE_SAMPLE_TPDO = 1,      /* process data decoded from a TPDO */
  COBRIDGE_SAMPLE_EMCY = 2,      /* an EMCY frame (CiA 301 §7.2.7) */
  COBRIDGE_SAMPLE_HEARTBEAT = 3, /* a heartbeat / boot-up frame (CiA 301 §7.2.8.3.2) */
  COBRIDGE_SAMPLE_NMT_STATE = 4, /* the node's NMT state changed as seen by the master */
  COBRIDGE_SAMPLE_STATUS = 5,    /* the gateway's view changed: online / stale */
  COBRIDGE_SAMPLE_COMMAND = 6    /* ABI 2: a submitted command finished (command_* fields) */
};

/* Bits of cobridge_sample.valid: which of the optional fields hold data.
 * The header fields (timestamps .. sync_counter, cob_id) are always set. */
enum cobridge_sample_valid {
  COBRIDGE_VALID_POSITION = 1u << 0,
  COBRIDGE_VALID_POSITION_ENG = 1u << 1,
  COBRIDGE_VALID_SPEED = 1u << 2,
  COBRIDGE_VALID_CAM_STATE = 1u << 3,
  COBRIDGE_VALID_WORK_AREA_STATE = 1u << 4,
  COBRIDGE_VALID_ALARMS = 1u << 5,
  COBRIDGE_VALID_WARNINGS = 1u << 6,
  COBRIDGE_VALID_TEMPERATURE = 1u << 7,
  COBRIDGE_VALID_VOLTAGE = 1u << 8,
  COBRIDGE_VALID_NMT_STATE = 1u << 9,
  COBRIDGE_VALID_STATUS = 1u << 10, /* online and stale */
  COBRIDGE_VALID_EMCY = 1u << 11,   /* emcy_code, emcy_register, emcy_data */
  COBRIDGE_VALID_RAW = 1u << 12,    /* raw_len, raw */
  COBRIDGE_VALID_COMMAND = 1u << 13, /* ABI 2: command_tag, command_abort_code, command_kind, command_status */
  COBRIDGE_VALID_RX_MONOTONIC = 1u << 14, /* ABI 2: rx_monotonic_ns */
  COBRIDGE_VALID_KIND_SEQUENCE = 1u << 15 /* ABI 2: kind_sequence */
};

/* NMT states as they appear in the heartbeat byte (CiA 301 §7.2.8.3.2). */
enum cobridge_nmt_state {
  COBRIDGE_NMT_BOOT_UP = 0x00,
  COBRIDGE_NMT_STOPPED = 0x04,
  COBRIDGE_NMT_OPERATIONAL = 0x05,
  COBRIDGE_NMT_PRE_OPERATIONAL = 0x7F
};

/* One event of one device. Fixed size, trivially copyable, no pointers: it is
 * copied through lock-free rings and may be kept by value. Fields not flagged
 * in `valid` are zero. Offsets are part of the ABI (checked in
 * daemon/pipeline/sample.hpp). */
typedef struct cobridge_sample {
  /* Kernel receive time of the CAN frame that produced the sample
   * (SO_TIMESTAMP), ns since the Unix epoch; for STATUS samples that no frame
   * caused, the time the gateway noticed the change. */
  uint64_t rx_timestamp_ns;
  /* Time the dispatcher handed the sample to the plugins, same clock. */
  uint64_t publish_timestamp_ns;
  /* Per-device sequence number, +1 for every sample of the device (all
   * kinds); a gap means samples were dropped before the dispatcher. Wraps.
   * Per kind: kind_sequence. */
  uint32_t sequence;
  /* Index of the device in the gateway's device table (cobridge_device_info). */
  uint16_t device_index;
  /* Index of the CAN bus in the gateway's configuration. */
  uint8_t bus_index;
  /* CANopen node-ID, 1..127. */
  uint8_t node_id;
  /* enum cobridge_sample_kind. */
  uint8_t kind;
  /* SYNC counter of the SYNC that triggered a synchronous TPDO
   * (CiA 301 §7.2.5.3.3), 1..240; 0 = no counter (event-driven TPDO or a
   * SYNC without counter). */
  uint8_t sync_counter;
  /* Bitmask of enum cobridge_sample_valid. */
  uint16_t valid;
  /* Speed as the device reports it (object 0x6030), device units. */
  int32_t speed;
  /* Position in counts after the device's own scaling (object 0x6004). */
  int64_t position;
  /* Position in engineering units (cobridge_device_info.position_unit),
   * computed by the gateway from `position` and the configured scale. */
  double position_eng;
  /* Alarm bits (object 0x6503) and warning bits (object 0x6505). */
  uint16_t alarms;
  uint16_t warnings;
  /* Device temperature in 0.1 degC. */
  int16_t temperature_dC;
  /* Supply voltage in 0.1 V. */
  uint16_t voltage_dV;
  /* CAM state register, channel 1 (object 0x6300/1): bit n = CAM n+1. */
  uint8_t cam_state;
  /* Work area state register (object 0x6400/1). */
  uint8_t work_area_state;
  /* enum cobridge_nmt_state. */
  uint8_t nmt_state;
  /* 1 = the gateway hears the node (heartbeat/guarding alive), 0 = lost. */
  uint8_t online;
  /* 1 = the values are older than the device's configured max age. */
  uint8_t stale;
  /* EMCY error register (object 0x1001 copy in the EMCY frame, byte 2). */
  uint8_t emcy_register;
  /* EMCY error code (bytes 0..1 of the EMCY frame); 0x0000 = error reset. */
  uint16_t emcy_code;
  /* Manufacturer-specific EMCY bytes 3..7. */
  uint8_t emcy_data[5];
  /* Number of valid bytes in `raw`, 0..8. */
  uint8_t raw_len;
  /* 11-bit COB-ID of the frame that produced the sample; 0 if none. */
  uint16_t cob_id;
  /* The frame's payload, for plugins that want the undecoded bytes. */
  uint8_t raw[8];
  /* ABI 2, kind COBRIDGE_SAMPLE_COMMAND (COBRIDGE_VALID_COMMAND): the outcome
   * of a command submitted with cobridge_host_api.submit_command. Every
   * plugin receives it; the submitter recognises its own by the tag. */
  uint32_t command_tag;        /* cobridge_command.tag as submitted */
  uint32_t command_abort_code; /* the device's SDO abort code (CiA 301 §7.2.4.3.17) when refused, else 0 */
  uint8_t command_kind;        /* enum cobridge_command_kind */
  uint8_t command_status;      /* enum cobridge_command_status */
  uint8_t reserved_pad_[6];    /* zero */
  /* ABI 2 (COBRIDGE_VALID_RX_MONOTONIC): rx_timestamp_ns on CLOCK_MONOTONIC,
   * for ages that a step of the wall clock must not falsify (data age,
   * staleness); the published timestamps stay wall-clock. */
  uint64_t rx_monotonic_ns;
  /* ABI 2 (COBRIDGE_VALID_KIND_SEQUENCE): per device AND kind, +1 for
   * every sample of this kind of this device, assigned where `sequence` is
   * (the bus RX thread). A gap in it is exactly a lost sample of this kind,
   * so an output that publishes one kind per topic (DDS EncoderSample = TPDO,
   * EncoderEvent = EMCY) can number its topic with it: a subscriber's gap is
   * then a loss, never a heartbeat it was not sent. Starts at 1. Wraps. */
  uint32_t kind_sequence;
  /* Room for fields of later ABI versions; zero. */
  uint8_t reserved[20];
} cobridge_sample;

/* ------------------------------------------------------------------------ */
/* Devices                                                                  */

enum cobridge_device_change {
  COBRIDGE_DEVICE_ADDED = 1,   /* configured and (first) seen */
  COBRIDGE_DEVICE_CHANGED = 2, /* identity or configuration changed */
  COBRIDGE_DEVICE_REMOVED = 3  /* removed from the configuration */
};

/* Describes one device; given to on_device when a device appears or
 * changes. The strings are NUL-terminated UTF-8 and valid only for the
 * duration of the call: copy what you keep. Unknown strings are "" (never
 * NULL). Grows at its end like the other sized structs. */
typedef struct cobridge_device_info {
  uint32_t struct_size;
  uint16_t device_index; /* matches cobridge_sample.device_index */
  uint8_t bus_index;
  uint8_t node_id;
  uint8_t change; /* enum cobridge_device_change */
  uint8_t reserved_[3];
  /* Identity object 0x1018 sub-indices 1..4. */
  uint32_t vendor_id;
  uint32_t product_code;
  uint32_t revision;
  uint32_t serial;
  const char* name;          /* configured device name, unique in the gateway */
  const char* bus_name;      /* e.g. "can0" */
  const char* model;         /* product name from the device description */
  const char* family;        /* device description family, e.g. "rotary" */
  const char* position_unit; /* unit of position_eng, e.g. "deg", "mm" */
  /* ABI 6 (read it only when struct_size covers it): enum
   * cobridge_config_state. A change of it comes as COBRIDGE_DEVICE_CHANGED. */
  uint8_t config_state;
} cobridge_device_info;

/* ABI 6: whether the device carries its configuration. Values are frozen. */
enum cobridge_config_state {
  COBRIDGE_CONFIG_AS_CONFIGURED = 0, /* nothing a client wrote differs from the configuration */
  COBRIDGE_CONFIG_DIFFERS = 1,       /* a client set a configured object to another value */
  COBRIDGE_CONFIG_CONTESTED = 2      /* ... and kept setting it after 3 restores within 10 minutes:
                                        the gateway writes it no more until an operator acknowledges */
};

/* ------------------------------------------------------------------------ */
/* Commands (ABI 2): what a plugin may ask the daemon to do to a device     */

/* Values are frozen; new kinds are only added. */
enum cobridge_command_kind {
  /* Set the position to `value` (counts, after scaling): the family's preset
   * object (0x6003; rotary series 0x6010 per channel), written and read
   * back. Volatile until a STORE. */
  COBRIDGE_COMMAND_PRESET = 1,
  /* NMT reset node (CiA 301 §7.2.8.3.1.1); the device boots and the gateway
   * configures it again, as after any boot-up. */
  COBRIDGE_COMMAND_NMT_RESET = 2,
  /* 'save' the device's parameters to its non-volatile memory (object
   * 0x1010, the family's sub-indices); the device passes through
   * pre-operational where the family requires it and is started again. */
  COBRIDGE_COMMAND_STORE = 3
};

/* Returned by submit_command (OK = queued; anything else = refused now) and
 * reported in cobridge_sample.command_status (OK = done). Values are frozen. */
enum cobridge_command_status {
  COBRIDGE_COMMAND_OK = 0,
  COBRIDGE_COMMAND_UNKNOWN_DEVICE = 1, /* no configured device has this device_index */
  COBRIDGE_COMMAND_OFFLINE = 2,        /* the device is not operational / not heard */
  COBRIDGE_COMMAND_BUSY = 3,           /* it is being configured or runs another command, or the queue is full */
  COBRIDGE_COMMAND_UNSUPPORTED = 4,    /* unknown kind, or the device's description lacks the object */
  COBRIDGE_COMMAND_INVALID_VALUE = 5,  /* value outside the object's type or limits */
  COBRIDGE_COMMAND_REFUSED = 6,        /* the device answered with an SDO abort (command_abort_code) */
  COBRIDGE_COMMAND_TIMEOUT = 7,        /* the device did not answer */
  COBRIDGE_COMMAND_FAILED = 8          /* anything else: bus down, value did not stick, daemon stopping */
};

typedef struct cobridge_command {
  uint32_t struct_size;  /* sizeof(cobridge_command) as the plugin saw it */
  uint16_t device_index; /* cobridge_sample.device_index of the device */
  uint8_t kind;          /* enum cobridge_command_kind */
  uint8_t reserved_;
  uint32_t tag;          /* chosen by the plugin; comes back in the COMMAND sample */
  uint32_t reserved2_;
  int64_t value;         /* PRESET: the position; otherwise 0 */
} cobridge_command;

/* ------------------------------------------------------------------------ */
/* Host API: what the daemon gives a plugin                                 */

/* Log levels, the daemon's (spdlog's) order. */
enum cobridge_log_level {
  COBRIDGE_LOG_TRACE = 0,
  COBRIDGE_LOG_DEBUG = 1,
  COBRIDGE_LOG_INFO = 2,
  COBRIDGE_LOG_WARN = 3,
  COBRIDGE_LOG_ERROR = 4,
  COBRIDGE_LOG_CRITICAL = 5
};

/* Valid from cobridge_plugin_create until destroy returns. */
typedef struct cobridge_host_api {
  uint32_t abi_version; /* the daemon's COBRIDGE_PLUGIN_ABI_VERSION */
  uint32_t struct_size; /* sizeof(cobridge_host_api) in the daemon */
  void* host;           /* pass back as the first argument of log() */
  /* Writes one line to the daemon's log, tagged with the plugin instance's
   * name. Thread-safe; not for the per-sample path. */
  void (*log)(void* host, int level, const char* msg);
  /* The gateway's configured id, e.g. for topic names. */
  const char* gateway_id;

  /* ABI 2 (present when struct_size covers it): hands a command for one
   * device to the daemon. Any plugin thread; never blocks (the daemon queues
   * it for the device's bus). Returns COBRIDGE_COMMAND_OK when queued: the
   * outcome then arrives, once, as a COBRIDGE_SAMPLE_COMMAND sample of that
   * device carrying the same tag (to every plugin). Any other value of enum
   * cobridge_command_status: refused now, nothing queued, no sample follows. */
  int (*submit_command)(void* host, const cobridge_command* command);

  /* ABI 4: the gateway's node-ID in a hot-standby pair ([redundancy]
   * node_id), 0 = the gateway runs alone. In a pair both gateways decode
   * every frame and hand the same samples to their plugins; an output that
   * must present one stream (DDS: EXCLUSIVE ownership) follows on_role. */
  uint32_t redundancy_node;
} cobridge_host_api;

/* ------------------------------------------------------------------------ */
/* Roles (ABI 4): which gateway of a hot-standby pair is a bus's master      */

/* Values are frozen; new roles are only added. */
enum cobridge_role {
  COBRIDGE_ROLE_UNDECIDED = 0, /* starting, negotiating or claiming */
  COBRIDGE_ROLE_MASTER = 1,    /* this gateway configures and commands the bus */
  COBRIDGE_ROLE_STANDBY = 2    /* another gateway (master_node) does; this one listens */
};

typedef struct cobridge_role_info {
  uint32_t struct_size;
  uint8_t bus_index;   /* index of the CAN bus in the gateway's configuration */
  uint8_t role;        /* enum cobridge_role */
  uint8_t own_node;    /* this gateway's node-ID on the bus */
  uint8_t master_node; /* the bus's master gateway, 0 = none known */
  uint8_t peer_node;   /* the other gateway heard on the bus, 0 = none yet */
  uint8_t reserved_[7];
  uint64_t since_ns;   /* when the role changed, ns since the Unix epoch */
  const char* bus_name; /* e.g. "can0" */
  const char* cause;    /* why, in words, e.g. "the active master is silent" */
} cobridge_role_info;

/* ------------------------------------------------------------------------ */
/* Bus health (ABI 5): the interface and its CAN controller                 */

/* The controller's fault confinement state (ISO 11898-1; error-warning is
 * Linux's level at an error counter of 96). Values are frozen. */
enum cobridge_controller_state {
  COBRIDGE_CONTROLLER_UNKNOWN = 0,       /* nothing told a state yet (e.g. vcan before any error frame) */
  COBRIDGE_CONTROLLER_ERROR_ACTIVE = 1,
  COBRIDGE_CONTROLLER_ERROR_WARNING = 2,
  COBRIDGE_CONTROLLER_ERROR_PASSIVE = 3,
  COBRIDGE_CONTROLLER_BUS_OFF = 4
};

/* Where the controller figures came from. Values are frozen. */
enum cobridge_controller_source {
  COBRIDGE_SOURCE_NONE = 0,         /* neither: state unknown, counters not known */
  COBRIDGE_SOURCE_ERROR_FRAMES = 1, /* the driver's CAN error frames (can.rst CAN_ERR_CRTL, CAN_ERR_CNT) */
  COBRIDGE_SOURCE_NETLINK = 2       /* the driver's IFLA_CAN_STATE / IFLA_CAN_BERR_COUNTER */
};

/* One bus's health; given to on_bus at start and whenever it changes (a
 * state transition or the interface opening/closing at once, counters at
 * most once a second). The string is valid only during the call. Grows at
 * its end like the other sized structs: read struct_size first. */
typedef struct cobridge_bus_info {
  uint32_t struct_size;
  uint8_t bus_index;        /* index of the CAN bus in the gateway's configuration */
  uint8_t open;             /* 1 = the CAN interface is open (up and bound) */
  uint8_t state;            /* enum cobridge_controller_state */
  uint8_t source;           /* enum cobridge_controller_source */
  uint8_t counters_known;   /* 1 = tx_errors / rx_errors hold what the driver reported */
  uint8_t driver_reports_state; /* 1 = the driver gives its state over netlink, 0 = it does not (vcan), 2 = not known yet */
  uint16_t tx_errors;       /* transmit error counter (0 when not known) */
  uint16_t rx_errors;       /* receive error counter (0 when not known) */
  uint8_t reserved_[10];
  uint64_t restarts;        /* controller restarts after bus-off (CAN_ERR_RESTARTED) */
  uint64_t error_frames;    /* CAN error frames received on the bus */
  uint64_t since_ns;        /* when the state last changed, ns since the Unix epoch; 0 = never */
  const char* bus_name;     /* the configured bus name */
} cobridge_bus_info;

/* ------------------------------------------------------------------------ */
/* Plugin operations: what a plugin gives the daemon                        */

/* One figure an output reports about itself (ABI 3, ops->stats), e.g. the
 * Modbus clients connected or the DDS writers. */
enum cobridge_stat_kind {
  COBRIDGE_STAT_GAUGE = 0,  /* a level that goes up and down */
  COBRIDGE_STAT_COUNTER = 1 /* only grows while the instance runs */
};

typedef struct cobridge_stat {
  /* lower_snake_case, stable (it becomes a metric name
   * cobridge_output_<name>, plus _total for a counter); static storage. */
  const char* name;
  const char* help; /* one line for people; static storage */
  uint32_t kind;    /* enum cobridge_stat_kind */
  uint32_t reserved_;
  uint64_t value;
} cobridge_stat;

typedef struct cobridge_plugin_ops {
  uint32_t abi_version; /* COBRIDGE_PLUGIN_ABI_VERSION the plugin was built with */
  uint32_t struct_size; /* sizeof(cobridge_plugin_ops) as the plugin saw it */
  const char* name;     /* plugin type name, e.g. "jsontap"; static storage */

  /* Mandatory operations, present in every ABI version. */

  /* Acquire resources (open files, sockets, threads). 0 = started; any other
   * value = failed (log the reason through host->log first); the daemon then
   * destroys the instance without calling stop. */
  int (*start)(void* self);
  /* Release what start acquired; after it returns no op but destroy is
   * called. Only called after a successful start. */
  void (*stop)(void* self);
  /* Free the instance. Always the last call; also used when the daemon
   * refuses the ops table right after create. */
  void (*destroy)(void* self);
  /* A batch of samples, in the order the dispatcher received them. The
   * array is valid only during the call. Dispatcher thread; must not block. */
  void (*on_samples)(void* self, const cobridge_sample* samples, size_t count);

  /* Optional operations: the daemon calls them only if struct_size covers
   * them and the pointer is not NULL. */

  /* A device appeared or changed. Dispatcher thread; must not block. */
  void (*on_device)(void* self, const cobridge_device_info* info);

  /* ABI 3. Fills up to `max` figures and returns how many it filled. Called
   * between start and stop from a thread of the daemon's control plane
   * (status page, /metrics, `cobridge status`), never the dispatcher, at most
   * a few times a second: it must be thread-safe against the plugin's own
   * threads, must not block, and should read counters, not compute. */
  size_t (*stats)(void* self, cobridge_stat* out, size_t max);

  /* ABI 4. The gateway's role on one bus changed (only with [redundancy]).
   * Dispatcher thread, in order with on_samples; must not block. */
  void (*on_role)(void* self, const cobridge_role_info* info);

  /* ABI 5. A bus's health changed (cobridge_bus_info), and once per bus
   * at start. Dispatcher thread, in order with on_samples; must not block.
   * A plugin built for ABI 4 or older has a struct_size that stops before
   * it, so the daemon never calls it there. */
  void (*on_bus)(void* self, const cobridge_bus_info* info);

  /* Later versions append here, never in between, and bump
   * COBRIDGE_PLUGIN_ABI_VERSION. */
} cobridge_plugin_ops;

/* The end of the mandatory part of cobridge_plugin_ops: a table smaller than
 * this is malformed. */
#define COBRIDGE_PLUGIN_OPS_MIN_SIZE \
  (offsetof(cobridge_plugin_ops, on_samples) + sizeof(void (*)(void)))

/* The entry point every plugin exports under COBRIDGE_PLUGIN_ENTRY.
 *
 * host        the host API; valid until destroy returns.
 * config_toml the instance's configuration: the keys of its table in the
 *             daemon configuration, without the keys the daemon itself uses
 *             to pick the plugin (type, file), as TOML text (not
 *             NUL-terminated; may be empty).
 * ops_out     receives the plugin's operation table (static storage).
 * self_out    receives the instance pointer passed to every operation.
 * err,err_len on failure, a NUL-terminated reason (truncated to err_len).
 *
 * Returns 0 on success; any other value means no instance was created and
 * nothing needs to be destroyed. A plugin that needs a newer daemon checks
 * host->abi_version here and fails with a message. */
typedef int (*cobridge_plugin_create_fn)(const cobridge_host_api* host, const char* config_toml,
                                         size_t config_len, const cobridge_plugin_ops** ops_out,
                                         void** self_out, char* err, size_t err_len);

COBRIDGE_PLUGIN_EXPORT int cobridge_plugin_create(const cobridge_host_api* host, const char* config_toml,
                                                  size_t config_len, const cobridge_plugin_ops** ops_out,
                                                  void** self_out, char* err, size_t err_len);

#ifdef __cplusplus
}
#endif

#endif /* COBRIDGE_PLUGIN_H */
