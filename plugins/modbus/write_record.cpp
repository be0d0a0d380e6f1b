#include "write_record.hpp"

#include "request.hpp"

#include <cstdio>

namespace cobridge::modbus {
namespace {

std::uint16_t word_at(std::span<const std::uint8_t> f, std::size_t at) {
  return static_cast<std::uint16_t>((f[at] << 8) | f[at + 1]);
}

std::string hex4(std::uint16_t v) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "0x%04X", v);
  return buf;
}

// "registers 100..101 = 0x0001 0x86A0" from the request's PDU.
std::string registers_text(std::span<const std::uint8_t> req, bool single) {
  const std::size_t pdu = kMbapHeaderSize;
  const std::uint16_t first = word_at(req, pdu + 1);
  if (single) return "register " + std::to_string(first) + " = " + hex4(word_at(req, pdu + 3));
  const std::uint16_t count = word_at(req, pdu + 3);
  std::string text = "registers " + std::to_string(first) + ".." + std::to_string(first + count - 1) + " =";
  for (std::size_t i = 0; i < count && pdu + 6 + 2 * i + 1 < req.size(); ++i)
    text += " " + hex4(word_at(req, pdu + 6 + 2 * i));
  return text;
}

}  // namespace

std::optional<std::string> describe_write(std::string_view client, std::span<const std::uint8_t> request,
                                          std::span<const std::uint8_t> response) {
  if (request.size() < kMbapHeaderSize + 5 || response.size() < kMbapHeaderSize + 2) return std::nullopt;
  const std::uint8_t fn = request[kMbapHeaderSize];
  const bool single = fn == static_cast<std::uint8_t>(FunctionCode::kWriteSingleRegister);
  if (!single && fn != static_cast<std::uint8_t>(FunctionCode::kWriteMultipleRegisters)) return std::nullopt;
  std::string line = "write by " + std::string(client) + " (unit " + std::to_string(request[6]) + "): " +
                     registers_text(request, single);
  const bool refused = (response[kMbapHeaderSize] & 0x80u) != 0;
  if (refused) {
    char code[8];
    std::snprintf(code, sizeof code, "0x%02X", response[kMbapHeaderSize + 1]);
    return line + ": refused, exception " + code;
  }
  return line + ": applied";
}

}  // namespace cobridge::modbus
