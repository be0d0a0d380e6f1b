// PayloadBuilder: one Sparkplug B payload (spec 6.4.2) built on protobuf-c
// structures the builder owns in fixed arrays, and packed into the caller's
// buffer. Why protobuf-c: C structures we can fill in place (no message
// objects on the heap, unlike libprotobuf's C++ classes), one
// protobuf_c_message_pack into a buffer we own, and a small runtime from
// Debian (libprotobuf-c1); nanopb is not packaged in Debian 12.
//
// Strings handed to the builder are referenced, not copied: they must live
// until pack() returns. A metric beyond kMaxMetrics or a property beyond
// kMaxProperties is refused (the add returns false), never truncated
// silently.
//
// Thread contract: one builder per thread (the plugin's publisher thread, or
// the MQTT client thread for the NDEATH will). No allocation.
#pragma once

#include "sparkplug_metrics.hpp"
#include "sparkplug_b.pb-c.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

namespace cobridge::mqtt {

using PbPayload = Org__Eclipse__Tahu__Protobuf__Payload;
using PbMetric = Org__Eclipse__Tahu__Protobuf__Payload__Metric;
using PbPropertySet = Org__Eclipse__Tahu__Protobuf__Payload__PropertySet;
using PbPropertyValue = Org__Eclipse__Tahu__Protobuf__Payload__PropertyValue;

class PayloadBuilder {
 public:
  static constexpr std::size_t kMaxMetrics = 48;
  static constexpr std::size_t kMaxProperties = 48;

  PayloadBuilder() noexcept;
  PayloadBuilder(const PayloadBuilder&) = delete;
  PayloadBuilder& operator=(const PayloadBuilder&) = delete;

  // Starts a payload: timestamp in ms; seq absent for NDEATH (spec 6.4.19).
  void begin(std::uint64_t timestamp_ms, std::optional<std::uint8_t> seq) noexcept;

  // One metric. alias 0 = none (name only); name nullptr = alias only (DDATA).
  [[nodiscard]] bool add_scalar(const char* name, std::uint64_t alias, std::uint64_t timestamp_ms, DataType type,
                                Scalar value) noexcept;
  [[nodiscard]] bool add_string(const char* name, std::uint64_t alias, std::uint64_t timestamp_ms, DataType type,
                                const char* value) noexcept;
  [[nodiscard]] bool add_null(const char* name, std::uint64_t alias, std::uint64_t timestamp_ms,
                              DataType type) noexcept;
  // A string property (e.g. engUnit, spec 6.4.7) of the last metric added.
  [[nodiscard]] bool add_property(const char* key, const char* value) noexcept;

  // Marks the last metric added as historical (spec 6.4.x Metric
  // is_historical: store and forward, tck-id-operational-behavior-data-*).
  void mark_historical() noexcept {
    if (payload_.n_metrics == 0) return;
    metrics_[payload_.n_metrics - 1].has_is_historical = 1;
    metrics_[payload_.n_metrics - 1].is_historical = 1;
  }
  // Sets the seq after the metrics (DDATA takes one only when it has any).
  void set_seq(std::uint8_t seq) noexcept {
    payload_.has_seq = 1;
    payload_.seq = seq;
  }
  [[nodiscard]] std::size_t metric_count() const noexcept { return payload_.n_metrics; }
  // Packs into `out`; returns the size, or 0 when it does not fit.
  [[nodiscard]] std::size_t pack(std::span<std::uint8_t> out) const noexcept;

 private:
  PbMetric* next_metric(const char* name, std::uint64_t alias, std::uint64_t timestamp_ms, DataType type) noexcept;

  PbPayload payload_;
  std::array<PbMetric, kMaxMetrics> metrics_;
  std::array<PbMetric*, kMaxMetrics> metric_ptrs_;
  // Property sets: one per metric at most; keys/values share one pool.
  std::array<PbPropertySet, kMaxMetrics> sets_;
  std::array<PbPropertyValue, kMaxProperties> values_;
  std::array<PbPropertyValue*, kMaxProperties> value_ptrs_;
  std::array<char*, kMaxProperties> keys_;
  std::size_t properties_ = 0;
};

// Sets the value fields of `m` for a scalar of `type` (spec 6.4.4: Int8..
// UInt32 in int_value, Int64/UInt64/DateTime in long_value, signed values as
// two's complement).
void set_scalar(PbMetric& m, DataType type, Scalar value) noexcept;

}  // namespace cobridge::mqtt
