// AsciiRequest: one command line of the CiA 309-3 ASCII gateway protocol,
// the command set `cocomm` (CANopenNode / CANopenLinux) and other 309-3
// clients speak, parsed; and the encoding of values by 309-3 data type.
//
//   [<seq>] [[<net>] <node>] r|read <index> <sub> [<type>]
//   [<seq>] [[<net>] <node>] w|write <index> <sub> <type> <value>
//   [<seq>] [[<net>] <node>] start | stop | preop | preoperational | reset node | reset comm[unication]
//   [<seq>] [<net>] lss_switch_glob 0|1 | lss_switch_sel <vendor> <product> <revision> <serial>
//                   | lss_set_node <node> | lss_store | lss_inquire_addr [0..3] | lss_get_node
//   [<seq>] [<net>] set network <net> | set node <node> | set sdo_timeout <ms>
//   [<seq>] info version | help
//
// Types: b, i8, i16, i32, i64, u8, u16, u32, u64, x8, x16, x32, x64, r32,
// r64, vs (visible string, "quoted" when it has blanks, "" for a quote), os
// (octet string as hex digits). Without a type a read answers the bytes as
// hex digits. Answers: "[<seq>] OK", "[<seq>] <value>", "[<seq>] ERROR: <code>"
// with the 309-3 error numbers below or an SDO abort code as 0xXXXXXXXX,
// each ended by CR LF (ascii_line). A request line ends with LF or CR LF.
// Integer values: decimal or 0x-hex, signed ones with an optional '-', the
// number refused (101) unless the type holds it (base/number_text.hpp).
//
// Thread: any; pure functions. Every byte sequence gives a request or an
// error number, never a crash.
#pragma once

#include "bus/service/service_request.hpp"

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace cobridge::control {

// CiA 309-3 error numbers ("ERROR: <n>").
enum class AsciiError : std::uint16_t {
  none = 0,
  not_supported = 100,
  syntax = 101,
  internal_state = 102,
  timeout = 103,
  no_default_net = 104,
  no_default_node = 105,
  unsupported_net = 106,
  unsupported_node = 107,
  lss_implementation = 501,
  lss_node_id = 502,
  lss_store = 504,
};

enum class AsciiType : std::uint8_t { none, b, i8, i16, i32, i64, u8, u16, u32, u64, x8, x16, x32, x64, r32, r64, vs, os };

struct AsciiRequest {
  enum class Kind : std::uint8_t { invalid, read, write, nmt, lss, set_network, set_node, set_sdo_timeout, info, help };
  Kind kind = Kind::invalid;
  std::string seq;        // the sequence number as sent (echoed); empty when none could be read
  unsigned net = 0;       // 0: the connection's default
  int node = -1;          // -1: the connection's default
  AsciiType type = AsciiType::none;
  bus::ServiceRequest command;  // read, write, nmt, lss: what to run (node filled in by the server)
  unsigned value = 0;     // set network / node / sdo_timeout
  AsciiError error = AsciiError::none;  // invalid
};

[[nodiscard]] AsciiRequest parse_ascii_request(std::string_view line);

// "[seq] OK" etc. (no line end: ascii_line adds it).
[[nodiscard]] std::string ascii_ok(std::string_view seq);
[[nodiscard]] std::string ascii_error(std::string_view seq, AsciiError error);
[[nodiscard]] std::string ascii_abort(std::string_view seq, std::uint32_t abort_code);
// An answer as it goes on the wire: ended by CR LF (CiA 309-3; `cocomm`
// reads an answer up to its "\r\n" and waits for ever on a bare LF).
[[nodiscard]] std::string ascii_line(std::string_view answer);
// The value of an upload as `type` says; nullopt when the size does not fit the type.
[[nodiscard]] std::optional<std::string> ascii_format(AsciiType type, std::span<const std::uint8_t> data);

}  // namespace cobridge::control
