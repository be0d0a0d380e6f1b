// The few CiA 301 SDO abort codes the encoder validation helpers return.
//
// The object-dictionary write hooks of the simulated device call the
// `check_*` helpers of this library and put a non-zero result straight on the
// wire, so these are the 32-bit wire values (CiA 301 §7.2.4.3.17). Only codes
// the Novotechnik manuals list (J§1.6.3, E§7.3) are used; F documents none.
// This library has no CANopen dependency, hence its own constants instead of
// canopen::SdoAbort (the values are identical).
// Thread-safety: constants only.
#pragma once

#include <cstdint>

namespace cobridge::sim::abort_code {

inline constexpr std::uint32_t kOk = 0;
inline constexpr std::uint32_t kSubIndexDoesNotExist = 0x06090011;  // J, E "subindex does not exist"
inline constexpr std::uint32_t kValueExceeded = 0x06090030;         // J, E "value exceeded"
inline constexpr std::uint32_t kWrongState = 0x08000022;            // J "unfair status", E "wrong state"

}  // namespace cobridge::sim::abort_code
