// Topics: the names and writer QoS of the three DDS topics the plugin
// publishes (see cobridge.idl and docs/dds.md).
//
//   EncoderSample  best-effort or reliable (configured), keep-last N (1),
//                  volatile: a subscriber wants the newest value, not a backlog.
//   EncoderEvent   reliable, keep-last 32, volatile: events must not be lost
//                  in transit, but a late joiner gets no history.
//   DeviceStatus   reliable, transient-local, keep-last 1: a late joiner
//                  learns the current state of every device at once.
//   GatewayStatus  reliable, transient-local, keep-last 1, one instance per
//                  gateway (gateway_presence.hpp).
//
// Every writer has liveliness AUTOMATIC with the configured lease: Cyclone
// asserts it for the participant (ParticipantMessageData at a fraction of
// the lease) and a reader that hears nothing from the gateway's participant
// for one lease marks its instances NOT_ALIVE_NO_WRITERS. Readers ask for
// no liveliness (infinite lease) or a lease >= the writers'.
//
// Reliable writers wait at most kMaxBlocking for room in their history (the
// dispatcher thread must not stall); a write that times out is counted as a
// failure, never retried.
//
// Thread contract: the control thread (plugin start), tests and the bench.
#pragma once

#include "dds/dds_config.hpp"

#include <dds/dds.h>

#include <memory>
#include <string>
#include <string_view>

namespace cobridge::dds {

inline constexpr std::string_view kEncoderSampleTopic = "EncoderSample";
inline constexpr std::string_view kEncoderEventTopic = "EncoderEvent";
inline constexpr std::string_view kDeviceStatusTopic = "DeviceStatus";
inline constexpr std::string_view kGatewayStatusTopic = "GatewayStatus";

inline constexpr int32_t kEventDepth = 32;
inline constexpr dds_duration_t kMaxBlocking = DDS_MSECS(1);

[[nodiscard]] std::string topic_name(std::string_view prefix, std::string_view topic);

struct QosDelete {
  void operator()(dds_qos_t* qos) const noexcept { dds_delete_qos(qos); }
};
using Qos = std::unique_ptr<dds_qos_t, QosDelete>;

// `lease` is the writers' liveliness lease (DdsConfig::liveliness_lease).
// `max_blocking`: kMaxBlocking on the writer thread; 0 when the dispatcher
// writes reliable samples itself (a full history cache then fails the write
// at once instead of waiting).
[[nodiscard]] Qos encoder_sample_writer_qos(Reliability reliability, int32_t depth, dds_duration_t lease,
                                            dds_duration_t max_blocking = kMaxBlocking);
[[nodiscard]] Qos encoder_event_writer_qos(dds_duration_t lease);
[[nodiscard]] Qos device_status_writer_qos(dds_duration_t lease);
[[nodiscard]] Qos gateway_status_writer_qos(dds_duration_t lease);
// The plugin's own GatewayStatus reader (duplicate detection): matches the
// writers of every gateway, ignores the plugin's own participant.
[[nodiscard]] Qos gateway_status_reader_qos();
// A hot-standby pair's data writer: EXCLUSIVE ownership at `strength`
// (pair_role.hpp).
void set_exclusive(dds_qos_t* qos, std::int32_t strength);
// The publisher / subscriber QoS of a partition ("" = the default one).
[[nodiscard]] Qos partition_qos(const std::string& partition);

}  // namespace cobridge::dds
