#include "dcmd_request.hpp"

#include "device_record.hpp"
#include "sparkplug_payload.hpp"

#include <cobridge/plugin.h>

#include <cstdio>
#include <cstring>

namespace cobridge::mqtt {
namespace {

constexpr auto kBool = ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__METRIC__VALUE_BOOLEAN_VALUE;
constexpr auto kLong = ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__METRIC__VALUE_LONG_VALUE;
constexpr auto kInt = ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__METRIC__VALUE_INT_VALUE;
constexpr auto kString = ORG__ECLIPSE__TAHU__PROTOBUF__PAYLOAD__METRIC__VALUE_STRING_VALUE;

template <typename... Args>
void say(DcmdRequest& r, const char* fmt, Args... args) noexcept {
  std::snprintf(r.error, sizeof r.error, fmt, args...);
  r.kind = 0;
}

// The metric's name for messages: its name, else "alias N".
void label_of(const PbMetric& m, char (&out)[48]) noexcept {
  if (m.name != nullptr)
    std::snprintf(out, sizeof out, "'%s'", m.name);
  else
    std::snprintf(out, sizeof out, "alias %llu", static_cast<unsigned long long>(m.alias));
}

// Which command metric `m` is, by name or by alias; nullptr if none.
const MetricDef* command_metric_of(const PbMetric& m, DcmdRequest& r) noexcept {
  for (const MetricDef& d : command_metrics()) {
    if (m.name != nullptr && std::strcmp(m.name, d.name) == 0) return &d;
    if (m.name == nullptr && m.has_alias != 0 && (m.alias & 0xFFu) == static_cast<std::uint64_t>(d.id) &&
        m.alias >= 256u) {
      r.alias_device = static_cast<std::int32_t>((m.alias >> 8) - 1u);
      return &d;
    }
  }
  return nullptr;
}

// One metric of the DCMD; false (with r.error) when it is not acceptable.
bool take_metric(const PbMetric& m, DcmdRequest& r) noexcept {
  char label[48];
  label_of(m, label);
  const MetricDef* d = command_metric_of(m, r);
  if (d == nullptr || d->id == DeviceMetric::kCmdResult || d->id == DeviceMetric::kCmdResultCode) {
    say(r, "metric %s is not a command of this device (Command/Preset, Command/NMT Reset, Command/Store, "
           "Command/Client)", label);
    return false;
  }
  if (d->id == DeviceMetric::kCmdClient) {
    if (m.value_case != kString || m.string_value == nullptr || m.string_value[0] == '\0') {
      say(r, "metric %s (Command/Client) must be a non-empty String", label);
      return false;
    }
    copy_text(r.client, m.string_value);
    return true;
  }
  if (r.kind != 0) {
    say(r, "metric %s: one command per DCMD (%s already given)", label, command_name(r.kind));
    return false;
  }
  if (d->id == DeviceMetric::kCmdPreset) {
    if (m.value_case != kLong && m.value_case != kInt) {
      say(r, "metric %s (Command/Preset) must be an integer (Int64)", label);
      return false;
    }
    // Signed values travel as two's complement (spec 6.4.4).
    r.value = m.value_case == kLong ? static_cast<std::int64_t>(m.long_value)
                                    : static_cast<std::int64_t>(static_cast<std::int32_t>(m.int_value));
    r.kind = COBRIDGE_COMMAND_PRESET;
    return true;
  }
  if (m.value_case != kBool || m.boolean_value == 0) {
    say(r, "metric %s (%s) must be the Boolean true", label, d->name);
    return false;
  }
  r.kind = d->id == DeviceMetric::kCmdNmtReset ? COBRIDGE_COMMAND_NMT_RESET : COBRIDGE_COMMAND_STORE;
  return true;
}

}  // namespace

const char* command_name(std::uint8_t kind) noexcept {
  switch (kind) {
    case COBRIDGE_COMMAND_PRESET: return "preset";
    case COBRIDGE_COMMAND_NMT_RESET: return "nmt_reset";
    case COBRIDGE_COMMAND_STORE: return "store";
    default: return "?";
  }
}

DcmdRequest parse_dcmd(std::string_view device_id, const std::uint8_t* data, std::size_t len) noexcept {
  DcmdRequest r;
  const std::size_t n = device_id.size() < sizeof r.device_id - 1 ? device_id.size() : sizeof r.device_id - 1;
  std::memcpy(r.device_id, device_id.data(), n);
  PbPayload* p = data != nullptr && len != 0 ? org__eclipse__tahu__protobuf__payload__unpack(nullptr, len, data)
                                              : nullptr;
  if (p == nullptr) {
    say(r, "the payload (%zu bytes) is not a Sparkplug B payload", len);
    return r;
  }
  bool ok = true;
  for (std::size_t i = 0; ok && i < p->n_metrics; ++i) ok = take_metric(*p->metrics[i], r);
  org__eclipse__tahu__protobuf__payload__free_unpacked(p, nullptr);
  if (!ok) return r;
  if (r.kind == 0) {
    say(r, "%s", "no command metric (Command/Preset, Command/NMT Reset or Command/Store)");
  } else if (r.client[0] == '\0') {
    say(r, "%s", "no Command/Client metric: a command must name its sender");
  }
  return r;
}

}  // namespace cobridge::mqtt
