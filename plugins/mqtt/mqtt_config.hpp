// MqttConfig: the Sparkplug output's settings, parsed from the TOML text of
// its [outputs.mqtt] table (docs/mqtt.md "Configuration"). Unknown keys are
// errors naming the key; every refusal says which key and why.
//
//   host            = "127.0.0.1"   broker host name or address
//   port            = 1883          broker port (1..65535)
//   client_id       = "cobridge-<edge_node_id>"
//   group_id        = "cobridge"    Sparkplug group id
//   edge_node_id    = <gateway id>  Sparkplug edge node id
//   keepalive_s     = 30            MQTT keepalive (5..65535; libmosquitto's floor is 5)
//   username        = (absent)      MQTT user name
//   password_file   = (absent)      file holding the password (mode 0600 or
//                                   stricter; its first line); needs username
//   ca_file         = (absent)      TLS: CA certificate(s) (PEM); turns TLS on
//   cert_file, key_file = (absent)  TLS client certificate and key (both or neither; need ca_file)
//   primary_host_id = (absent)      hold births and data until spBv1.0/STATE/<id> says online
//   queue_depth     = 8192          samples buffered between the dispatcher and the publisher
//   batch_samples   = 32            DDATA of one device batched within one pass of the
//                                   publisher (what queued while it published): at most
//                                   this many samples per device and message; 0 = one
//                                   DDATA per sample
//   store_seconds   = 30            store and forward: DDATA kept per device while the
//                                   broker is away, at most this old (0 = off)
//   store_rate      = 50            ... and at most store_seconds x this many entries
//                                   per device (preallocated; oldest dropped first)
//   bdseq_file      = "/var/lib/cobridge/mqtt-<edge_node_id>.bdseq"
//                                   the last bdSeq used, kept across restarts
//                                   (bdseq_file.hpp); "" = in memory only
//   writes_enabled  = false         take DCMD commands (preset, NMT reset, store)
//   write_allow     = []            which: device names, "<device>:<command>", "*:<command>"
//                                   (write_policy.hpp); empty = every device and command
//   [outputs.mqtt.deadband]         per metric name: a change smaller than this is not sent
//     Position = 10                 (report by exception; absent = every change is sent)
//   [outputs.mqtt.metrics]          per device name, or "*" for every device not named:
//     "*" = ["Position", "Stale"]   the process metrics it publishes (DBIRTH, DDATA,
//     rot-a = ["Position", "Speed"] history); absent = all (docs/mqtt.md, metric table)
//
// Thread contract: parsed on the daemon's control thread (plugin create).
#pragma once

#include "sparkplug_metrics.hpp"
#include "write_policy.hpp"

#include <cobridge/plugin_error.hpp>

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

namespace cobridge::mqtt {

struct MqttConfig {
  std::string host = "127.0.0.1";
  std::uint16_t port = 1883;
  std::string client_id;  // default filled from edge_node_id
  std::string group_id = "cobridge";
  std::string edge_node_id;  // default: the gateway id
  std::uint32_t keepalive_s = 30;
  std::string username;
  std::string password;  // read from password_file, never from the TOML
  std::string ca_file;
  std::string cert_file;
  std::string key_file;
  std::string primary_host_id;
  std::uint32_t queue_depth = 8192;
  std::uint32_t batch_samples = 32;
  WritePolicy writes;
  std::string bdseq_file;  // default filled from edge_node_id; "" = not persisted
  bool bdseq_file_set = false;
  std::uint32_t store_seconds = 30;
  std::uint32_t store_rate = 50;
  // Indexed by process_index(DeviceMetric); 0 = every change is sent.
  std::array<double, 16> deadband{};
  MetricSets metrics;

  MqttConfig() { deadband.fill(0.0); }
  [[nodiscard]] bool tls() const noexcept { return !ca_file.empty(); }
};

// Fills `out` only on success. gateway_id: the default edge node id. The
// error's message starts "config: " and names the key.
[[nodiscard]] plugin::Error parse_config(std::string_view toml_text, std::string_view gateway_id, MqttConfig& out);

// Whether `host` names this machine's loopback ("localhost", 127.0.0.0/8,
// "::1"): a plaintext connection anywhere else sends the credentials and the
// data readable on the network, which the plugin warns about at load.
[[nodiscard]] bool is_loopback_host(std::string_view host) noexcept;

// The warning for a plaintext broker outside loopback; "" when there is none.
[[nodiscard]] std::string plaintext_warning(const MqttConfig& c);

// Sparkplug ids (group, edge node, device) may not hold '/', '+' or '#'
// (spec 4.1.1, tck-id-topic-structure-namespace-valid-*) and may not be empty.
[[nodiscard]] bool valid_sparkplug_id(std::string_view id) noexcept;

}  // namespace cobridge::mqtt
