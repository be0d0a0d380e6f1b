#include "dds/sample_mapping.hpp"

#include <cstring>
#include <string_view>

namespace cobridge::dds {
namespace {

// The generated structs take `char*`; Cyclone's serializer only reads them.
char* str(const char* s) noexcept { return const_cast<char*>(s != nullptr ? s : ""); }

template <std::size_t N>
void copy_view(std::array<char, N>& dst, std::string_view src) noexcept {
  const std::size_t n = src.size() < N - 1 ? src.size() : N - 1;
  if (n > 0) std::memcpy(dst.data(), src.data(), n);
  dst[n] = '\0';
}

// The valid bits the IDL defines (the process values); the plugin.h bits
// above them describe sample kinds the other topics carry.
constexpr unsigned kSampleValidMask =
    COBRIDGE_VALID_POSITION | COBRIDGE_VALID_POSITION_ENG | COBRIDGE_VALID_SPEED | COBRIDGE_VALID_CAM_STATE |
    COBRIDGE_VALID_WORK_AREA_STATE | COBRIDGE_VALID_ALARMS | COBRIDGE_VALID_WARNINGS | COBRIDGE_VALID_TEMPERATURE |
    COBRIDGE_VALID_VOLTAGE;
static_assert(cobridge_VALID_POSITION == COBRIDGE_VALID_POSITION && cobridge_VALID_VOLTAGE == COBRIDGE_VALID_VOLTAGE &&
                  cobridge_VALID_TEMPERATURE == COBRIDGE_VALID_TEMPERATURE,
              "cobridge.idl VALID_* must equal plugin.h COBRIDGE_VALID_*");

}  // namespace

void describe_emcy(const char* family, const cobridge_sample& s, EmcyText& out) noexcept {
  cobridge_emcy_info info{};
  if (cobridge_emcy_classify(family, s.emcy_code, s.emcy_register, s.emcy_data, &info) != 0) {
    out = EmcyText{};
    return;
  }
  copy_view(out.text, std::string_view(info.text, info.text_len));
  copy_view(out.source, std::string_view(info.source, info.source_len));
  out.error_reset = info.error_reset != 0;
}

std::uint64_t gateway_key(std::string_view gateway_id) noexcept {
  std::uint64_t h = 0xcbf29ce484222325ull;  // FNV-1a 64 offset basis and prime (public domain)
  for (const char c : gateway_id) h = (h ^ static_cast<unsigned char>(c)) * 0x100000001b3ull;
  return h;
}

std::uint32_t topic_sequence(const cobridge_sample& s) noexcept {
  return (s.valid & COBRIDGE_VALID_KIND_SEQUENCE) != 0 ? s.kind_sequence : s.sequence;
}

void fill_encoder_sample(cobridge_EncoderSample& out, const cobridge_sample& s, const GatewayName& gateway,
                         const DeviceSlot* slot, bool stale) noexcept {
  out.gateway_key = gateway.key;
  out.gateway_id = str(gateway.id);
  out.bus = s.bus_index;
  out.node_id = s.node_id;
  out.device_name = str(slot != nullptr ? slot->name.c_str() : "");
  out.position = s.position;
  out.position_eng = s.position_eng;
  out.speed = s.speed;
  out.cam_state = s.cam_state;
  out.work_area_state = s.work_area_state;
  out.alarms = s.alarms;
  out.warnings = s.warnings;
  out.temperature_dC = s.temperature_dC;
  out.voltage_dV = s.voltage_dV;
  out.valid = static_cast<std::uint16_t>(s.valid & kSampleValidMask);
  out.rx_timestamp_ns = s.rx_timestamp_ns;
  out.publish_timestamp_ns = s.publish_timestamp_ns;
  out.sequence_number = topic_sequence(s);
  out.sync_counter = s.sync_counter;
  out.stale = stale;
}

void fill_encoder_event(cobridge_EncoderEvent& out, const cobridge_sample& s, const GatewayName& gateway,
                        const DeviceSlot* slot, const EmcyText& text) noexcept {
  out.gateway_key = gateway.key;
  out.gateway_id = str(gateway.id);
  out.bus = s.bus_index;
  out.node_id = s.node_id;
  out.device_name = str(slot != nullptr ? slot->name.c_str() : "");
  out.code = s.emcy_code;
  out.error_register = s.emcy_register;
  std::memcpy(out.data, s.emcy_data, sizeof out.data);
  out.text = str(text.text.data());
  out.source = str(text.source.data());
  out.error_reset = text.error_reset;
  out.rx_timestamp_ns = s.rx_timestamp_ns;
  out.publish_timestamp_ns = s.publish_timestamp_ns;
  out.sequence_number = topic_sequence(s);
}

void fill_device_status(cobridge_DeviceStatus& out, const DeviceSlot& slot, const GatewayName& gateway) noexcept {
  out.gateway_key = gateway.key;
  out.gateway_id = str(gateway.id);
  out.bus = slot.bus_index;
  out.node_id = slot.node_id;
  out.name = str(slot.name.c_str());
  out.bus_name = str(slot.bus_name.c_str());
  out.vendor_id = slot.vendor_id;
  out.product_code = slot.product_code;
  out.revision = slot.revision;
  out.serial = slot.serial;
  out.model = str(slot.model.c_str());
  out.family = str(slot.family.c_str());
  out.position_unit = str(slot.position_unit.c_str());
  out.nmt_state = slot.state.nmt_state;
  out.online = slot.state.online;
  out.stale = slot.state.stale;
  out.last_emcy_code = slot.state.last_emcy_code;
  out.last_emcy_register = slot.state.last_emcy_register;
  out.last_emcy_ns = slot.state.last_emcy_ns;
  out.updated_ns = slot.state.updated_ns;
  out.config_state = slot.config_state;
}

}  // namespace cobridge::dds
