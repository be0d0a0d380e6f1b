// Topics: the names and writer QoS of the three DDS topics the plugin
// publishes (see cobridge.idl and docs/dds.md).
//
//   EncoderSample  best-effort or reliable (configured), keep-last N (1),
//                  volatile: a subscriber wants the newest value, not a backlog.
//   EncoderEvent   reliable, keep-last 32, volatile: events must not be lost
//                  in transit, but a late joiner gets no history.
//   DeviceStatus   reliable, transient-local, keep-last 1: a late joiner
//                  learns the current state of every device at once.
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

inline constexpr int32_t kEventDepth = 32;
inline constexpr dds_duration_t kMaxBlocking = DDS_MSECS(1);

[[nodiscard]] std::string topic_name(std::string_view prefix, std::string_view topic);

struct QosDelete {
  void operator()(dds_qos_t* qos) const noexcept { dds_delete_qos(qos); }
};
using Qos = std::unique_ptr<dds_qos_t, QosDelete>;

[[nodiscard]] Qos encoder_sample_writer_qos(Reliability reliability, int32_t depth);
[[nodiscard]] Qos encoder_event_writer_qos();
[[nodiscard]] Qos device_status_writer_qos();

}  // namespace cobridge::dds
