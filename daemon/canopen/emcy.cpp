#include "canopen/emcy.hpp"

#include <cstdio>

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

std::string_view to_string(DeviceFamily family) noexcept {
  switch (family) {
    case DeviceFamily::generic: return "generic";
    case DeviceFamily::novotechnik_rotary: return "novotechnik_rotary";
    case DeviceFamily::ifm_rm: return "ifm_rm";
    case DeviceFamily::novotechnik_multiturn: return "novotechnik_multiturn";
  }
  return "unknown";
}

std::string_view to_string(EmcyLevel level) noexcept {
  switch (level) {
    case EmcyLevel::unspecified: return "unspecified";
    case EmcyLevel::info: return "Info";
    case EmcyLevel::warn: return "Warn";
    case EmcyLevel::error: return "Error";
    case EmcyLevel::hard: return "Hard";
  }
  return "unknown";
}

namespace {

uint16_t le16(const Emcy& e, std::size_t first) noexcept {
  return static_cast<uint16_t>(e.manufacturer[first] | (e.manufacturer[first + 1] << 8));
}

EmcyInfo generic_info(const Emcy& e) noexcept {
  EmcyInfo info;
  info.text = cia301_text(e.error_code);
  info.source = "CiA 301";
  info.error_reset = (e.error_code >> 8) == 0x00;
  return info;
}

// J§1.8.1. Byte 2 is the error register; the 0x8110 rows differ in bytes 3-4.
EmcyInfo rotary_info(const Emcy& e) noexcept {
  EmcyInfo info;
  info.source = "J§1.8.1";
  info.from_manual = true;
  switch (e.error_code) {
    case 0x0000:
      info.text = "sensor error reset, no error";
      info.error_reset = true;
      return info;
    case 0x5000: info.text = "sensor error (internal error bit set)"; return info;
    case 0x6000:
      info.text = "event timer value insufficient for the bit rate; TPDO1 sent only partially";
      return info;
    case 0x8110:
      if (le16(e, 0) == 1) {
        info.text = "CAN controller overflow, CAN overrun; data lost";
        return info;
      }
      if (le16(e, 0) == 2) {
        info.text = "CAN buffer overflow (CANopen library buffer full); data lost";
        return info;
      }
      break;
    case 0x8120: info.text = "CAN error passive"; return info;
    case 0x8140: info.text = "CAN recovered from bus-off"; return info;
    case 0x9080: info.text = "encoder CAM state changed (coded as 0x6300)"; return info;
    case 0x9090: info.text = "work area state changed (coded as 0x6400)"; return info;
    default: break;
  }
  return generic_info(e);
}

struct MultiturnRow {
  uint16_t code;
  uint8_t byte2;
  uint8_t byte3;
  EmcyLevel level;
  int32_t position;  // 0 = none given
  std::string_view text;
};

// E§9.1, row by row.
constexpr MultiturnRow kMultiturnRows[] = {
    {0x0000, 0, 0, EmcyLevel::hard, 0, "sensor error reset, no error"},
    {0x1000, 1, 0, EmcyLevel::hard, kMultiturnErrorPosition, "unknown error"},
    {0x3100, 1, 0, EmcyLevel::error, 0, "supply voltage fault"},
    {0x3100, 1, 1, EmcyLevel::warn, 0, "supply voltage overrun (factory-set threshold max exceeded)"},
    {0x3100, 1, 2, EmcyLevel::warn, 0, "supply voltage underrun (factory-set threshold min exceeded)"},
    {0x4210, 1, 1, EmcyLevel::warn, 0, "temperature overrun (factory-set threshold max exceeded)"},
    {0x4210, 1, 2, EmcyLevel::warn, 0, "temperature underrun (factory-set threshold min exceeded)"},
    {0x5000, 1, 0, EmcyLevel::hard, kMultiturnErrorPosition, "device hardware fault"},
    {0x5000, 0, 0, EmcyLevel::info, 0, "life guarding error"},
    {0x5000, 0, 1, EmcyLevel::info, 0, "maintenance required (operating time limit)"},
    {0x5000, 1, 2, EmcyLevel::hard, kMultiturnErrorPosition, "hardware ASIC fault"},
    {0x5000, 2, 0, EmcyLevel::hard, 0, "memory lost"},
    {0x5051, 0, 0, EmcyLevel::unspecified, 0, "valid position"},
    {0x5051, 1, 0, EmcyLevel::error, kMultiturnErrorPosition, "measurement error"},
    {0x5051, 1, 1, EmcyLevel::error, kMultiturnOverflowPosition,
     "position overflow error, out of range (+); reset via 0x2100"},
    {0x5051, 1, 2, EmcyLevel::error, kMultiturnUnderflowPosition,
     "position underflow error, out of range (-); reset via 0x2100"},
    {0x5051, 2, 1, EmcyLevel::warn, kMultiturnOverflowPosition, "position overflow warning"},
    {0x5051, 2, 2, EmcyLevel::warn, kMultiturnUnderflowPosition, "position underflow warning"},
    {0x6000, 1, 0, EmcyLevel::hard, kMultiturnErrorPosition, "device software fault"},
    {0x6000, 2, 0, EmcyLevel::hard, 0,
     "insufficient event timer value for the bit rate; TPDO1 sent only partially"},
    {0x8110, 1, 0, EmcyLevel::hard, 0, "CAN controller overflow, CAN overrun; data lost"},
    {0x8110, 2, 0, EmcyLevel::hard, 0, "CAN buffer overflow (CANopen library buffer full); data lost"},
    {0x8120, 0, 0, EmcyLevel::hard, 0, "CAN error passive"},
    {0x8140, 0, 0, EmcyLevel::hard, 0, "CAN recovered from bus-off"},
    {0x9080, 1, 0, EmcyLevel::warn, 0, "encoder CAM state changed"},
    {0x9090, 1, 0, EmcyLevel::warn, 0, "work area state changed"},
};

EmcyInfo multiturn_info(const Emcy& e) noexcept {
  for (const MultiturnRow& row : kMultiturnRows) {
    if (row.code != e.error_code || row.byte2 != e.error_register || row.byte3 != e.manufacturer[0])
      continue;
    EmcyInfo info;
    info.text = row.text;
    info.source = "E§9.1";
    info.level = row.level;
    info.from_manual = true;
    info.error_reset = row.code == 0x0000 || (row.code == 0x5051 && row.byte2 == 0);
    if (row.position != 0) info.position_value = row.position;
    return info;
  }
  return generic_info(e);
}

}  // namespace

EmcyInfo classify(DeviceFamily family, const Emcy& emcy) noexcept {
  switch (family) {
    case DeviceFamily::novotechnik_rotary: return rotary_info(emcy);
    case DeviceFamily::novotechnik_multiturn: return multiturn_info(emcy);
    // F documents no EMCY codes (F§4, B.6 of the digest): CiA 301 only.
    case DeviceFamily::ifm_rm:
    case DeviceFamily::generic: break;
  }
  return generic_info(emcy);
}

std::optional<std::string_view> error_position_meaning(DeviceFamily family,
                                                       int32_t position) noexcept {
  switch (family) {
    case DeviceFamily::novotechnik_rotary:
      if (position == kRotaryErrorPosition) return "position or sensor error (J§1.8)";
      break;
    case DeviceFamily::novotechnik_multiturn:
      if (position == kMultiturnErrorPosition)
        return "measurement, unknown, hardware, ASIC or software error (E§9.1)";
      if (position == kMultiturnOverflowPosition) return "position out of range (+) (E§9.1)";
      if (position == kMultiturnUnderflowPosition) return "position out of range (-) (E§9.1)";
      break;
    case DeviceFamily::ifm_rm:
    case DeviceFamily::generic: break;
  }
  return std::nullopt;
}

namespace {

std::string hex(unsigned value, int digits) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%0*X", digits, value);
  return buf;
}

std::string work_area_bits(uint8_t state) {
  // 0x6400: bit 0 out of range, bit 1 range overflow, bit 2 range underflow.
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

}  // namespace

std::string describe(DeviceFamily family, const Emcy& e) {
  const EmcyInfo info = classify(family, e);
  std::string s = "EMCY " + hex(e.error_code, 4) + " " + std::string(info.text) + " (" +
                  std::string(info.source) + ")";
  if (info.level != EmcyLevel::unspecified) s += ", level " + std::string(to_string(info.level));

  const bool rotary = family == DeviceFamily::novotechnik_rotary && info.from_manual;
  const bool multiturn = family == DeviceFamily::novotechnik_multiturn && info.from_manual;
  if (rotary && e.error_code == emcy_code::kNovotechnikCam) {
    s += ", channel " + std::to_string(le16(e, 0)) + ", CAMs " + hex(le16(e, 2), 2) +
         ", state " + hex(e.manufacturer[4], 2);
  } else if (rotary && e.error_code == emcy_code::kNovotechnikWorkArea) {
    s += ", channel " + std::to_string(le16(e, 0)) + ", state " + hex(e.manufacturer[4], 2) +
         " (" + work_area_bits(e.manufacturer[4]) + ")";
  } else if (multiturn && e.error_code == emcy_code::kNovotechnikCam) {
    s += ", changed CAMs " + hex(e.manufacturer[1], 2) + ", state " + hex(e.manufacturer[4], 2);
  } else if (multiturn && e.error_code == emcy_code::kNovotechnikWorkArea) {
    // E§9.1 codes the state "according to 0x6400" and also lists 0/1/2 =
    // valid/underflow/overflow; the two disagree, so show both readings.
    const uint8_t st = e.manufacturer[4];
    std::string_view enumerated = st == 0 ? "valid" : st == 1 ? "underflow" : st == 2 ? "overflow" : "?";
    s += ", state " + hex(st, 2) + " (as 0x6400 bits: " + work_area_bits(st) +
         "; as E§9.1 list: " + std::string(enumerated) + ")";
  }

  if (multiturn) {
    // Byte 2 is a sub-code in E§9.1, not the CiA error register.
    s += ", sub-code " + std::to_string(e.error_register) + "/" + std::to_string(e.manufacturer[0]);
  } else {
    s += ", error register " + hex(e.error_register, 2) + " [" +
         error_register_text(e.error_register) + "]";
  }
  if (info.position_value)
    s += ", position reads " + hex(static_cast<uint32_t>(*info.position_value), 8);
  return s;
}

Emcy rotary_cam_emcy(uint16_t channel, uint16_t cams, uint8_t state) noexcept {
  Emcy e;
  e.error_code = emcy_code::kNovotechnikCam;
  e.error_register = 1;
  e.manufacturer = {static_cast<uint8_t>(channel & 0xFF), static_cast<uint8_t>(channel >> 8),
                    static_cast<uint8_t>(cams & 0xFF), static_cast<uint8_t>(cams >> 8), state};
  return e;
}

Emcy rotary_work_area_emcy(uint16_t channel, uint8_t state) noexcept {
  Emcy e;
  e.error_code = emcy_code::kNovotechnikWorkArea;
  e.error_register = 1;
  e.manufacturer = {static_cast<uint8_t>(channel & 0xFF), static_cast<uint8_t>(channel >> 8), 0, 0,
                    state};
  return e;
}

Emcy multiturn_cam_emcy(uint8_t changed, uint8_t state) noexcept {
  Emcy e;
  e.error_code = emcy_code::kNovotechnikCam;
  e.error_register = 1;
  e.manufacturer = {0, changed, 0, 0, state};
  return e;
}

Emcy multiturn_work_area_emcy(uint8_t state) noexcept {
  Emcy e;
  e.error_code = emcy_code::kNovotechnikWorkArea;
  e.error_register = 1;
  e.manufacturer = {0, 0, 0, 0, state};
  return e;
}

}  // namespace cobridge::canopen
