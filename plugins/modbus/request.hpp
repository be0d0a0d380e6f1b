// Request: the Modbus TCP request path done by hand — MBAP framing, PDU
// validation and response building — so that no untrusted byte reaches
// libmodbus (3.1.6 overflows on some malformed requests) or the register
// image before every field has been checked.
//
// Frame layout (Modbus Messaging on TCP/IP Implementation Guide V1.0b §3.1.3):
//   transaction id (2) | protocol id (2, must be 0) | length (2) | unit id (1) | PDU
// where length counts the unit id and the PDU: 2..254 (a PDU is 1..253 bytes,
// Modbus Application Protocol V1.1b3 §4.1).
//
// What happens to a bad request:
//   - framing errors (protocol id != 0, length outside 2..254, a PDU shorter
//     or longer than its function needs) close the connection: the stream
//     can no longer be trusted to be in step;
//   - everything else gets an exception response, checks in the order of
//     the Application Protocol's state diagrams (§6.3 ff.): function (0x01),
//     quantity (0x03), address (0x02), then execution (0x04, 0x06, 0x0B);
//   - a write (0x06, 0x10) while writes are disabled answers 0x01; an
//     enabled one is checked for quantity and map range here and then handed
//     to the WriteTarget, which decides what is writable (0x02/0x03 for the
//     rest) and answers with an exception or nothing (then the normal echo).
//
// Thread contract: pure functions (but for what the WriteTarget does),
// called from the Modbus server thread (and the fuzz target); noexcept, no
// allocation.
#pragma once

#include "register_image.hpp"

#include <cstddef>
#include <cstdint>
#include <span>

namespace cobridge::modbus {

// Modbus exception codes, as on the wire (Application Protocol §7).
enum class ExceptionCode : std::uint8_t {
  kNone = 0x00,
  kIllegalFunction = 0x01,
  kIllegalDataAddress = 0x02,
  kIllegalDataValue = 0x03,
  kServerDeviceFailure = 0x04,
  kServerDeviceBusy = 0x06,
  kGatewayPathUnavailable = 0x0A,
  kGatewayTargetFailed = 0x0B,
};

// The function codes this server understands (Application Protocol §6).
enum class FunctionCode : std::uint8_t {
  kReadHoldingRegisters = 0x03,
  kReadInputRegisters = 0x04,
  kWriteSingleRegister = 0x06,
  kWriteMultipleRegisters = 0x10,
};

inline constexpr std::size_t kMbapHeaderSize = 7;  // including the unit id
inline constexpr std::size_t kMaxFrameSize = 260;  // 6 + 254
inline constexpr std::uint16_t kMinLengthField = 2;
inline constexpr std::uint16_t kMaxLengthField = 254;
inline constexpr std::uint16_t kMaxReadQuantity = 125;   // §6.3: 1..0x7D
inline constexpr std::uint16_t kMaxWriteQuantity = 123;  // §6.12: 1..0x7B

enum class FrameState : std::uint8_t {
  kIncomplete,  // need more bytes
  kComplete,    // a whole frame of `length` bytes is at the front
  kInvalid,     // protocol id or length field is wrong: close
};

struct FrameCheck {
  FrameState state = FrameState::kIncomplete;
  std::size_t length = 0;
};

// Looks at the bytes received so far on a connection. Decides as early as
// possible: a wrong protocol id is rejected after 4 bytes, a wrong length
// after 6, without waiting for the rest.
[[nodiscard]] FrameCheck check_frame(std::span<const std::uint8_t> received) noexcept;

// Configuration that affects request handling.
struct RequestPolicy {
  int unit_id = -1;  // -1 = answer any unit id, else only this one
  bool writes_enabled = false;
  bool offline_exception = false;
};

enum class Verdict : std::uint8_t { kExecute, kException, kClose };

// A request that passed validation (kExecute), or the reason it did not.
struct Validation {
  Verdict verdict = Verdict::kClose;
  ExceptionCode exception = ExceptionCode::kNone;
  std::uint16_t transaction = 0;
  std::uint8_t unit = 0;
  std::uint8_t function = 0;
  std::uint16_t address = 0;
  std::uint16_t quantity = 0;
};

// Where enabled, validated writes go (the plugin's CommandRegisters).
class WriteTarget {
 public:
  virtual ~WriteTarget() = default;
  // Registers [address, address + values.size()), inside the map. Returns
  // kNone when applied, else the exception to answer (nothing applied).
  [[nodiscard]] virtual ExceptionCode write(std::uint16_t address, std::span<const std::uint16_t> values,
                                            ReadTime now) noexcept = 0;
};

// Validates one complete frame (as delimited by check_frame) against the
// policy and a map of `map_registers` registers.
[[nodiscard]] Validation validate_request(std::span<const std::uint8_t> frame, const RequestPolicy& policy,
                                          std::uint32_t map_registers) noexcept;

// Handles one complete frame: validates it, reads the image, and writes the
// response into `out` (at least kMaxFrameSize bytes). Returns the response
// length, or 0 if the connection must be closed.
// Writes go to `writes`; without one every write answers 0x02.
[[nodiscard]] std::size_t handle_request(std::span<const std::uint8_t> frame, const RegisterImage& image,
                                         const RequestPolicy& policy, ReadTime now, std::span<std::uint8_t> out,
                                         WriteTarget* writes = nullptr) noexcept;

// Writes an exception response (function | 0x80, code); returns its length (9).
std::size_t write_exception(std::uint16_t transaction, std::uint8_t unit, std::uint8_t function, ExceptionCode code,
                            std::span<std::uint8_t> out) noexcept;

}  // namespace cobridge::modbus
