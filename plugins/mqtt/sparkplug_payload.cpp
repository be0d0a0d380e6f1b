#include "sparkplug_payload.hpp"

namespace cobridge::mqtt {

PayloadBuilder::PayloadBuilder() noexcept : payload_(ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__INIT) {
  for (std::size_t i = 0; i < kMaxMetrics; ++i) metric_ptrs_[i] = &metrics_[i];
  for (std::size_t i = 0; i < kMaxProperties; ++i) value_ptrs_[i] = &values_[i];
}

void PayloadBuilder::begin(std::uint64_t timestamp_ms, std::optional<std::uint8_t> seq) noexcept {
  payload_ = ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__INIT;
  payload_.has_timestamp = 1;
  payload_.timestamp = timestamp_ms;
  payload_.has_seq = seq.has_value() ? 1 : 0;
  payload_.seq = seq.value_or(0);
  payload_.metrics = metric_ptrs_.data();
  payload_.n_metrics = 0;
  properties_ = 0;
}

PbMetric* PayloadBuilder::next_metric(const char* name, std::uint64_t alias, std::uint64_t timestamp_ms,
                                      DataType type) noexcept {
  if (payload_.n_metrics >= kMaxMetrics) return nullptr;
  PbMetric& m = metrics_[payload_.n_metrics++];
  m = ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__METRIC__INIT;
  m.name = const_cast<char*>(name);  // protobuf-c's char* fields are not written by pack
  m.has_alias = alias != 0 ? 1 : 0;
  m.alias = alias;
  m.has_timestamp = 1;
  m.timestamp = timestamp_ms;
  m.has_datatype = 1;
  m.datatype = static_cast<std::uint32_t>(type);
  return &m;
}

void set_scalar(PbMetric& m, DataType type, Scalar v) noexcept {
  switch (type) {
    case DataType::kInt64:
    case DataType::kUInt64:
    case DataType::kDateTime:
      m.value_case = ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__METRIC__VALUE_LONG_VALUE;
      m.long_value = static_cast<std::uint64_t>(v.i);
      break;
    case DataType::kFloat:
      m.value_case = ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__METRIC__VALUE_FLOAT_VALUE;
      m.float_value = static_cast<float>(v.d);
      break;
    case DataType::kDouble:
      m.value_case = ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__METRIC__VALUE_DOUBLE_VALUE;
      m.double_value = v.d;
      break;
    case DataType::kBoolean:
      m.value_case = ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__METRIC__VALUE_BOOLEAN_VALUE;
      m.boolean_value = v.i != 0 ? 1 : 0;
      break;
    default:  // Int8..UInt32
      m.value_case = ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__METRIC__VALUE_INT_VALUE;
      m.int_value = static_cast<std::uint32_t>(v.i);
      break;
  }
}

bool PayloadBuilder::add_scalar(const char* name, std::uint64_t alias, std::uint64_t timestamp_ms, DataType type,
                                Scalar value) noexcept {
  PbMetric* m = next_metric(name, alias, timestamp_ms, type);
  if (m == nullptr) return false;
  set_scalar(*m, type, value);
  return true;
}

bool PayloadBuilder::add_string(const char* name, std::uint64_t alias, std::uint64_t timestamp_ms, DataType type,
                                const char* value) noexcept {
  PbMetric* m = next_metric(name, alias, timestamp_ms, type);
  if (m == nullptr) return false;
  m->value_case = ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__METRIC__VALUE_STRING_VALUE;
  m->string_value = const_cast<char*>(value != nullptr ? value : "");
  return true;
}

bool PayloadBuilder::add_null(const char* name, std::uint64_t alias, std::uint64_t timestamp_ms,
                              DataType type) noexcept {
  PbMetric* m = next_metric(name, alias, timestamp_ms, type);
  if (m == nullptr) return false;
  m->has_is_null = 1;
  m->is_null = 1;
  return true;
}

bool PayloadBuilder::add_property(const char* key, const char* value) noexcept {
  if (payload_.n_metrics == 0 || properties_ >= kMaxProperties) return false;
  const std::size_t mi = payload_.n_metrics - 1;
  PbMetric& m = metrics_[mi];
  PbPropertySet& set = sets_[mi];
  if (m.properties == nullptr) {
    set = ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__PROPERTY_SET__INIT;
    set.keys = &keys_[properties_];
    set.values = &value_ptrs_[properties_];
    m.properties = &set;
  }
  // A metric's properties are contiguous in the pools: only the last metric
  // takes new ones, so its run is never interleaved with another's.
  PbPropertyValue& pv = values_[properties_];
  pv = ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__PROPERTY_VALUE__INIT;
  pv.has_type = 1;
  pv.type = static_cast<std::uint32_t>(DataType::kString);
  pv.value_case = ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__PROPERTY_VALUE__VALUE_STRING_VALUE;
  pv.string_value = const_cast<char*>(value);
  keys_[properties_] = const_cast<char*>(key);
  ++properties_;
  ++set.n_keys;
  ++set.n_values;
  return true;
}

std::size_t PayloadBuilder::pack(std::span<std::uint8_t> out) const noexcept {
  const auto* msg = reinterpret_cast<const ProtobufCMessage*>(&payload_);
  const std::size_t size = protobuf_c_message_get_packed_size(msg);
  if (size > out.size()) return 0;
  return protobuf_c_message_pack(msg, out.data());
}

}  // namespace cobridge::mqtt
