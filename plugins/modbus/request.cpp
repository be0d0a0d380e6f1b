#include "request.hpp"

#include <array>

namespace cobridge::modbus {
namespace {

std::uint16_t be16(const std::uint8_t* p) noexcept {
  return static_cast<std::uint16_t>((static_cast<unsigned>(p[0]) << 8) | p[1]);
}

void put_be16(std::uint8_t* p, std::uint16_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v >> 8);
  p[1] = static_cast<std::uint8_t>(v & 0xFFu);
}

void write_mbap(std::uint8_t* p, std::uint16_t transaction, std::uint8_t unit, std::size_t pdu_len) noexcept {
  put_be16(p, transaction);
  put_be16(p + 2, 0);
  put_be16(p + 4, static_cast<std::uint16_t>(pdu_len + 1));
  p[6] = unit;
}

Validation answer_exception(Validation v, ExceptionCode code) noexcept {
  v.verdict = Verdict::kException;
  v.exception = code;
  return v;
}

Validation must_close(Validation v) noexcept {
  v.verdict = Verdict::kClose;
  return v;
}

}  // namespace

FrameCheck check_frame(std::span<const std::uint8_t> received) noexcept {
  if (received.size() >= 4 && be16(received.data() + 2) != 0) return {FrameState::kInvalid, 0};
  if (received.size() < 6) return {FrameState::kIncomplete, 0};
  const std::uint16_t length = be16(received.data() + 4);
  if (length < kMinLengthField || length > kMaxLengthField) return {FrameState::kInvalid, 0};
  const std::size_t total = 6u + length;
  if (received.size() < total) return {FrameState::kIncomplete, 0};
  return {FrameState::kComplete, total};
}

Validation validate_request(std::span<const std::uint8_t> frame, const RequestPolicy& policy,
                            std::uint32_t map_registers) noexcept {
  Validation v;
  const FrameCheck fc = check_frame(frame);
  if (fc.state != FrameState::kComplete || fc.length != frame.size()) return must_close(v);
  v.transaction = be16(frame.data());
  v.unit = frame[6];
  const std::span<const std::uint8_t> pdu = frame.subspan(kMbapHeaderSize);  // 1..253 bytes
  v.function = pdu[0];

  // A gateway routes by unit id before it looks at the PDU (Implementation
  // Guide §4.4.1.2): another unit is a path this gateway does not have.
  if (policy.unit_id >= 0 && v.unit != static_cast<std::uint8_t>(policy.unit_id)) {
    return answer_exception(v, ExceptionCode::kGatewayPathUnavailable);
  }

  const auto function = static_cast<FunctionCode>(v.function);
  switch (function) {
    case FunctionCode::kReadHoldingRegisters:
    case FunctionCode::kReadInputRegisters: {
      if (pdu.size() != 5) return must_close(v);  // truncated or oversized
      v.address = be16(&pdu[1]);
      v.quantity = be16(&pdu[3]);
      if (v.quantity < 1 || v.quantity > kMaxReadQuantity) return answer_exception(v, ExceptionCode::kIllegalDataValue);
      if (static_cast<std::uint32_t>(v.address) + v.quantity > map_registers) {
        return answer_exception(v, ExceptionCode::kIllegalDataAddress);
      }
      v.verdict = Verdict::kExecute;
      return v;
    }
    case FunctionCode::kWriteSingleRegister: {
      if (pdu.size() != 5) return must_close(v);
      if (!policy.writes_enabled) return answer_exception(v, ExceptionCode::kIllegalFunction);
      v.address = be16(&pdu[1]);
      v.quantity = 1;
      if (static_cast<std::uint32_t>(v.address) + 1u > map_registers) {
        return answer_exception(v, ExceptionCode::kIllegalDataAddress);
      }
      v.verdict = Verdict::kExecute;  // which registers are writable: the WriteTarget
      return v;
    }
    case FunctionCode::kWriteMultipleRegisters: {
      if (pdu.size() < 6 || pdu.size() != 6u + pdu[5]) return must_close(v);
      if (!policy.writes_enabled) return answer_exception(v, ExceptionCode::kIllegalFunction);
      v.address = be16(&pdu[1]);
      v.quantity = be16(&pdu[3]);
      const std::uint8_t byte_count = pdu[5];
      if (v.quantity < 1 || v.quantity > kMaxWriteQuantity || byte_count != 2u * v.quantity) {
        return answer_exception(v, ExceptionCode::kIllegalDataValue);
      }
      if (static_cast<std::uint32_t>(v.address) + v.quantity > map_registers) {
        return answer_exception(v, ExceptionCode::kIllegalDataAddress);
      }
      v.verdict = Verdict::kExecute;
      return v;
    }
  }
  return answer_exception(v, ExceptionCode::kIllegalFunction);
}

std::size_t write_exception(std::uint16_t transaction, std::uint8_t unit, std::uint8_t function, ExceptionCode code,
                            std::span<std::uint8_t> out) noexcept {
  if (out.size() < kMbapHeaderSize + 2) return 0;
  write_mbap(out.data(), transaction, unit, 2);
  out[7] = static_cast<std::uint8_t>(function | 0x80u);
  out[8] = static_cast<std::uint8_t>(code);
  return kMbapHeaderSize + 2;
}

namespace {

// 0x06 / 0x10 after validation: the values to the target, then the echo
// (0x06: the request itself; 0x10: address and quantity, §6.6 / §6.12).
std::size_t handle_write(std::span<const std::uint8_t> frame, const Validation& v, ReadTime now,
                         std::span<std::uint8_t> out, WriteTarget* writes) noexcept {
  if (writes == nullptr) {
    return write_exception(v.transaction, v.unit, v.function, ExceptionCode::kIllegalDataAddress, out);
  }
  const std::span<const std::uint8_t> pdu = frame.subspan(kMbapHeaderSize);
  std::array<std::uint16_t, kMaxWriteQuantity> values{};
  const bool single = v.function == static_cast<std::uint8_t>(FunctionCode::kWriteSingleRegister);
  const std::size_t first_byte = single ? 3 : 6;
  for (std::size_t i = 0; i < v.quantity; ++i) values[i] = be16(&pdu[first_byte + 2 * i]);
  const ExceptionCode ec = writes->write(v.address, std::span(values.data(), v.quantity), now);
  if (ec != ExceptionCode::kNone) return write_exception(v.transaction, v.unit, v.function, ec, out);
  write_mbap(out.data(), v.transaction, v.unit, 5);
  out[7] = v.function;
  put_be16(&out[8], v.address);
  put_be16(&out[10], single ? values[0] : v.quantity);
  return kMbapHeaderSize + 5;
}

}  // namespace

std::size_t handle_request(std::span<const std::uint8_t> frame, const RegisterImage& image,
                           const RequestPolicy& policy, ReadTime now, std::span<std::uint8_t> out,
                           WriteTarget* writes) noexcept {
  if (out.size() < kMaxFrameSize) return 0;
  const Validation v = validate_request(frame, policy, image.size());
  switch (v.verdict) {
    case Verdict::kClose: return 0;
    case Verdict::kException: return write_exception(v.transaction, v.unit, v.function, v.exception, out);
    case Verdict::kExecute: break;
  }
  if (v.function == static_cast<std::uint8_t>(FunctionCode::kWriteSingleRegister) ||
      v.function == static_cast<std::uint8_t>(FunctionCode::kWriteMultipleRegisters)) {
    return handle_write(frame, v, now, out, writes);
  }
  std::array<std::uint16_t, kMaxReadQuantity> regs{};
  const ReadStatus st = image.read(v.address, std::span(regs.data(), v.quantity), now, policy.offline_exception);
  switch (st) {
    case ReadStatus::kOk: break;
    case ReadStatus::kOutOfRange:
      return write_exception(v.transaction, v.unit, v.function, ExceptionCode::kIllegalDataAddress, out);
    case ReadStatus::kOffline:
      return write_exception(v.transaction, v.unit, v.function, ExceptionCode::kGatewayTargetFailed, out);
    case ReadStatus::kBusy:
      return write_exception(v.transaction, v.unit, v.function, ExceptionCode::kServerDeviceFailure, out);
  }
  const std::size_t bytes = 2u * v.quantity;
  write_mbap(out.data(), v.transaction, v.unit, 2 + bytes);
  out[7] = v.function;
  out[8] = static_cast<std::uint8_t>(bytes);
  for (std::size_t i = 0; i < v.quantity; ++i) put_be16(&out[9 + 2 * i], regs[i]);
  return kMbapHeaderSize + 2 + bytes;
}

}  // namespace cobridge::modbus
