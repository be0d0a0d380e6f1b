#include "canopen/emcy.hpp"

#include "canopen/cob_id.hpp"

namespace cobridge::canopen {

std::string_view to_string(EmcyFrameError error) noexcept {
  switch (error) {
    case EmcyFrameError::none: return "ok";
    case EmcyFrameError::wrong_cob_id: return "not an EMCY COB-ID";
    case EmcyFrameError::wrong_length: return "EMCY data length is not 8";
    case EmcyFrameError::remote_request: return "unexpected remote request";
    case EmcyFrameError::extended_id: return "29-bit identifier";
  }
  return "unknown error";
}

EmcyParse decode_emcy(const can::Frame& frame) noexcept {
  EmcyParse r;
  if (frame.is_extended()) {
    r.error = EmcyFrameError::extended_id;
  } else if (frame.is_rtr()) {
    r.error = EmcyFrameError::remote_request;
  } else if (frame.len != 8) {
    r.error = EmcyFrameError::wrong_length;
  } else {
    r.emcy.error_code = static_cast<uint16_t>(frame.data[0] | (frame.data[1] << 8));
    r.emcy.error_register = frame.data[2];
    for (std::size_t i = 0; i < r.emcy.manufacturer.size(); ++i)
      r.emcy.manufacturer[i] = frame.data[3 + i];
  }
  return r;
}

EmcyParse parse_emcy(const can::Frame& frame) noexcept {
  if (!frame.is_extended() &&
      (frame.id < cob::kEmcyBase + cob::kNodeIdMin || frame.id > cob::kEmcyBase + cob::kNodeIdMax)) {
    EmcyParse r;
    r.error = EmcyFrameError::wrong_cob_id;
    return r;
  }
  EmcyParse r = decode_emcy(frame);
  if (r.ok()) r.node = static_cast<uint8_t>(frame.id - cob::kEmcyBase);
  return r;
}

can::Frame make_emcy_on(uint32_t cob_id, const Emcy& emcy) noexcept {
  std::array<uint8_t, 8> d{};
  d[0] = static_cast<uint8_t>(emcy.error_code & 0xFF);
  d[1] = static_cast<uint8_t>(emcy.error_code >> 8);
  d[2] = emcy.error_register;
  for (std::size_t i = 0; i < emcy.manufacturer.size(); ++i) d[3 + i] = emcy.manufacturer[i];
  return can::Frame::make8(cob_id, d);
}

can::Frame make_emcy(uint8_t node, const Emcy& emcy) noexcept {
  return make_emcy_on(cob::kEmcyBase + node, emcy);
}

// ---------------------------------------------------------------------------
// CiA 301 texts

std::string_view cia301_text(uint16_t code) noexcept {
  switch (code) {
    case 0x0000: return "error reset or no error";
    case 0x8110: return "CAN overrun (objects lost)";
    case 0x8120: return "CAN in error passive mode";
    case 0x8130: return "life guard error or heartbeat error";
    case 0x8140: return "recovered from bus off";
    case 0x8150: return "CAN-ID collision";
    case 0x8210: return "PDO not processed due to length error";
    case 0x8220: return "PDO length exceeded";
    case 0x8230: return "DAM MPDO not processed, destination object not available";
    case 0x8240: return "unexpected SYNC data length";
    case 0x8250: return "RPDO timeout";
    default: break;
  }
  switch (code >> 8) {
    case 0x00: return "error reset or no error";
    case 0x10: return "generic error";
    case 0x20: return "current, generic";
    case 0x21: return "current, device input side";
    case 0x22: return "current inside the device";
    case 0x23: return "current, device output side";
    case 0x30: return "voltage, generic";
    case 0x31: return "mains voltage";
    case 0x32: return "voltage inside the device";
    case 0x33: return "output voltage";
    case 0x40: return "temperature, generic";
    case 0x41: return "ambient temperature";
    case 0x42: return "device temperature";
    case 0x50: return "device hardware";
    case 0x60: return "device software, generic";
    case 0x61: return "internal software";
    case 0x62: return "user software";
    case 0x63: return "data set";
    case 0x70: return "additional modules";
    case 0x80: return "monitoring, generic";
    case 0x81: return "communication, generic";
    case 0x82: return "protocol error, generic";
    case 0x90: return "external error, generic";
    case 0xF0: return "additional functions, generic";
    case 0xFF: return "device specific, generic";
    default: break;
  }
  switch (code >> 12) {
    case 0x1: return "generic error";
    case 0x2: return "current";
    case 0x3: return "voltage";
    case 0x4: return "temperature";
    case 0x5: return "device hardware";
    case 0x6: return "device software";
    case 0x7: return "additional modules";
    case 0x8: return "monitoring";
    case 0x9: return "external error";
    default: return "reserved";
  }
}

std::string_view to_string(ErrorRegisterBit bit) noexcept {
  switch (bit) {
    case ErrorRegisterBit::generic: return "generic";
    case ErrorRegisterBit::current: return "current";
    case ErrorRegisterBit::voltage: return "voltage";
    case ErrorRegisterBit::temperature: return "temperature";
    case ErrorRegisterBit::communication: return "communication";
    case ErrorRegisterBit::device_profile: return "device profile specific";
    case ErrorRegisterBit::reserved: return "reserved";
    case ErrorRegisterBit::manufacturer: return "manufacturer specific";
  }
  return "unknown";
}

std::string error_register_text(uint8_t error_register) {
  if (error_register == 0) return "none";
  std::string s;
  for (unsigned bit = 0; bit < 8; ++bit) {
    const auto mask = static_cast<uint8_t>(1U << bit);
    if ((error_register & mask) == 0) continue;
    if (!s.empty()) s += '|';
    s += to_string(static_cast<ErrorRegisterBit>(mask));
  }
  return s;
}

std::string work_area_state_text(uint8_t state) {
  // CiA 406 0x6400: bit 0 out of range, bit 1 range overflow, bit 2 range underflow.
  if (state == 0) return "inside";
  std::string s;
  const auto add = [&s](std::string_view t) {
    if (!s.empty()) s += '|';
    s += t;
  };
  if (state & 0x01) add("out of range");
  if (state & 0x02) add("overflow");
  if (state & 0x04) add("underflow");
  return s;
}

}  // namespace cobridge::canopen
