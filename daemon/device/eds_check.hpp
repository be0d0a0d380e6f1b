// EDS check: whether a parsed device description is right for every tool
// that reads it, beyond what parse_eds refuses. parse_eds rejects files it
// cannot understand (syntax, unknown types, sections named in a list but
// missing); check_eds finds files that parse but would mislead a third-party
// master or cobridge itself:
//
//   CiA 306 §4.5   each object sits in the list its index belongs to
//                  (0x1000/0x1001/0x1018 mandatory, 0x2000-0x5FFF
//                  manufacturer, the rest optional), the mandatory objects exist
//   CiA 306 §4.6   an ARRAY/RECORD has sub-index 0 (UNSIGNED8, ro/const) whose
//                  default is the highest sub-index present and a SubNumber
//                  that counts its sub-objects; an ARRAY's entries share one type
//   CiA 301 §7.4.8 every default PDO mapping entry names an object the file
//                  defines, with PDOMapping=1, the entry's bit length equal
//                  to the object's type, readable (TPDO) / writable (RPDO)
//                  access, at most 64 entries and 64 bits per PDO; the
//                  mapping parameters are UNSIGNED32
//   CiA 306 §4.4   NrOfTXPDO / NrOfRXPDO count the PDO communication objects,
//                  each with its mapping object
//   the manual     every object the family's manual names (families)
//                  is defined
//
// Thread contract: a pure function of an immutable description; any thread,
// off the hot path (allocates). Used by the tests of every shipped EDS and by
// anything that loads user EDS files (the catalog's callers, the CLI).
#pragma once

#include <vector>

#include "base/error.hpp"
#include "device/eds.hpp"

namespace cobridge::device {

// Every finding as an Error of kind kInvalidArgument with an EdsErrc code,
// where = "<file> [<section>]". Empty when the description is right.
[[nodiscard]] std::vector<Error> check_eds(const DeviceDescription& description);

}  // namespace cobridge::device
