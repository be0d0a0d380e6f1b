// Fuzz target for the Modbus TCP request path of the Modbus output
// (plugins/modbus/request.hpp): framing (check_frame), validation
// (validate_request) and response building against a live register image
// (handle_request), the code every untrusted byte from a client goes
// through. Invariants checked on every answer (Modbus Messaging on TCP/IP
// Implementation Guide §3.1.3, Application Protocol §7): the response fits
// one ADU, its length field matches, the transaction and unit ids are
// echoed, the function code is the request's (| 0x80 for an exception), and
// exception codes are among those this server defines; a write that
// succeeds is echoed (0x06: the request; 0x10: address and quantity) and
// only ever touches the command registers (+28..+30 of a slot).
//
// Built two ways (tests/fuzz/CMakeLists.txt): with clang's libFuzzer
// (-fsanitize=fuzzer,address,undefined) when available, run for a bounded
// time by CTest; otherwise with standalone_driver.cpp, a deterministic
// mutation loop over the seed corpus under ASan/UBSan.
//
// Input layout: byte 0 picks the policy (unit filter, writes, offline
// exception) and the mode; the rest is either a raw TCP byte stream (cut into
// frames as the server does) or a PDU to be wrapped in a valid MBAP header, so
// that most inputs get past framing into PDU validation.
#include "command_registers.hpp"
#include "request.hpp"

#include <array>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace {

using namespace cobridge::modbus;

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "invariant violated: %s\n", what);
  std::abort();
}

const RegisterImage& image() {
  static RegisterImage* img = [] {
    ImageOptions o;
    o.device_slots = 8;
    auto* i = new RegisterImage(o);
    for (std::uint16_t d = 0; d < 6; ++d) {
      cobridge_sample s{};
      s.device_index = d;
      s.bus_index = static_cast<std::uint8_t>(d % 3);
      s.kind = COBRIDGE_SAMPLE_STATUS;
      s.sequence = 1;
      s.valid = COBRIDGE_VALID_STATUS | COBRIDGE_VALID_POSITION;
      s.online = d == 4 ? 0 : 1;  // one offline device for 0x0B
      s.position = -12345 * d;
      s.rx_timestamp_ns = 1'000'000'000;
      i->apply(s);
    }
    return i;
  }();
  return *img;
}

// The write path, with a daemon that accepts, refuses busy, or refuses
// offline in turn.
CommandRegisters& commands() {
  static CommandRegisters* c = new CommandRegisters(image(), [](const cobridge_command& cmd) {
    if (cmd.struct_size != sizeof(cobridge_command) || cmd.device_index >= 8) fail("submitted command");
    return static_cast<int>(cmd.tag % 3 == 0 ? COBRIDGE_COMMAND_OK
                            : cmd.tag % 3 == 1 ? COBRIDGE_COMMAND_BUSY
                                               : COBRIDGE_COMMAND_OFFLINE);
  });
  return *c;
}

void check_response(const std::uint8_t* req, std::size_t req_len, const std::uint8_t* r, std::size_t n) {
  if (n == 0) return;  // connection closed: always allowed
  if (n < kMbapHeaderSize + 2 || n > kMaxFrameSize) fail("response size");
  if (req_len < kMbapHeaderSize + 1) fail("answered a frame without PDU");
  const std::size_t length = (static_cast<std::size_t>(r[4]) << 8) | r[5];
  if (length + 6 != n) fail("MBAP length");
  if (r[2] != 0 || r[3] != 0) fail("protocol id");
  if (r[0] != req[0] || r[1] != req[1]) fail("transaction id not echoed");
  if (r[6] != req[6]) fail("unit id not echoed");
  const std::uint8_t fn = req[7];
  if (r[7] == static_cast<std::uint8_t>(fn | 0x80u)) {
    if (n != 9) fail("exception size");
    const std::uint8_t code = r[8];
    if (code != 0x01 && code != 0x02 && code != 0x03 && code != 0x04 && code != 0x06 && code != 0x0A &&
        code != 0x0B) {
      fail("exception code");
    }
    return;
  }
  if (r[7] != fn) fail("function code not echoed");
  if (fn == 0x06 || fn == 0x10) {
    if (n != 12 || std::memcmp(r + 7, req + 7, 5) != 0) fail("write echo");
    const std::size_t address = (static_cast<std::size_t>(req[8]) << 8) | req[9];
    const std::size_t qty = fn == 0x06 ? 1 : (static_cast<std::size_t>(req[10]) << 8) | req[11];
    const std::size_t first = (address - kDeviceBase) % kDeviceStride;
    if (address < kDeviceBase || first < 28 || first + qty - 1 > 30) fail("write outside the command registers");
    return;
  }
  if (fn != 0x03 && fn != 0x04) fail("only reads and writes may succeed");
  const std::size_t qty = (static_cast<std::size_t>(req[10]) << 8) | req[11];
  if (r[8] != 2 * qty || n != 9 + 2 * qty || qty < 1 || qty > kMaxReadQuantity) fail("read response size");
}

void run_stream(const std::uint8_t* data, std::size_t size, const RequestPolicy& policy) {
  // As the server does: a 260-byte input buffer, frames cut as they complete.
  std::array<std::uint8_t, kMaxFrameSize> in{};
  std::array<std::uint8_t, kMaxFrameSize> out{};
  std::size_t in_len = 0;
  std::size_t pos = 0;
  while (pos < size) {
    const std::size_t take = std::min(size - pos, in.size() - in_len);
    std::memcpy(in.data() + in_len, data + pos, take);
    in_len += take;
    pos += take;
    for (;;) {
      const FrameCheck fc = check_frame(std::span<const std::uint8_t>(in.data(), in_len));
      if (fc.state == FrameState::kInvalid) return;  // closed
      if (fc.state == FrameState::kIncomplete) break;
      if (fc.length < kMbapHeaderSize + 1 || fc.length > in_len) fail("frame length");
      const std::size_t n = handle_request(std::span<const std::uint8_t>(in.data(), fc.length), image(), policy,
                                           ReadTime{2'000'000'000, 3'000'000'000}, out, &commands());
      check_response(in.data(), fc.length, out.data(), n);
      if (n == 0) return;  // closed
      std::memmove(in.data(), in.data() + fc.length, in_len - fc.length);
      in_len -= fc.length;
    }
    if (in_len == in.size()) fail("full buffer without a complete frame");
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::uint8_t ctl = data[0];
  RequestPolicy policy;
  policy.unit_id = (ctl & 0x01) != 0 ? 1 : -1;
  policy.writes_enabled = (ctl & 0x02) != 0;
  policy.offline_exception = (ctl & 0x04) != 0;
  const std::uint8_t* body = data + 1;
  const std::size_t len = size - 1;

  // Any bytes at all must be safe to validate, framed or not.
  [[maybe_unused]] const Validation v =
      validate_request(std::span<const std::uint8_t>(body, len), policy, image().size());

  if ((ctl & 0x08) == 0) {
    run_stream(body, len, policy);
  } else {
    // Wrap the input as a PDU (truncated to the largest legal PDU).
    const std::size_t pdu = std::min<std::size_t>(len, 253);
    if (pdu == 0) return 0;
    std::vector<std::uint8_t> f(7 + pdu);
    f[0] = 0x12;
    f[1] = 0x34;
    f[4] = static_cast<std::uint8_t>((pdu + 1) >> 8);
    f[5] = static_cast<std::uint8_t>(pdu + 1);
    f[6] = (ctl & 0x10) != 0 ? 1 : 2;
    std::memcpy(f.data() + 7, body, pdu);
    run_stream(f.data(), f.size(), policy);
  }
  return 0;
}
