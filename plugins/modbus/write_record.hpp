// WriteRecord: the line an operator's log gets for each Modbus write
// (function 0x06 or 0x10): who wrote (the client's address and port), which
// registers, which values, and whether it was applied or refused with which
// exception. A write moves an encoder's preset or resets a node, so the
// journal must be able to say who did it.
//
// Thread contract: called by the server thread after a request is answered;
// allocates (a write is rare; reads never reach it).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace cobridge::modbus {

// `request` and `response`: one whole MBAP frame each, as handled. Nothing
// for a request that is not a write.
[[nodiscard]] std::optional<std::string> describe_write(std::string_view client,
                                                        std::span<const std::uint8_t> request,
                                                        std::span<const std::uint8_t> response);

}  // namespace cobridge::modbus
