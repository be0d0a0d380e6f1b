// CiA 306 Electronic Data Sheet (EDS): the INI-like file that describes a
// CANopen device's identity and object dictionary, parsed into an immutable
// DeviceDescription.
//
// Thread contract: parsing runs off the hot path (start-up or configuration
// reload thread); it allocates and may take milliseconds. A parsed
// DeviceDescription is immutable and may be read from any thread.
//
// The API never throws and never aborts on bad input: every problem in a file
// becomes an EdsError (file, line, column, code, message), and a file with any
// error yields no description, so a half-understood device is never used.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "base/error.hpp"
#include "canopen/data_type.hpp"

namespace cobridge::device {

// CiA 306 §4.6.3 ObjectType codes (the values written in the file).
enum class ObjectType : std::uint8_t {
  kNull = 0x0,
  kDomain = 0x2,
  kDefType = 0x5,
  kDefStruct = 0x6,
  kVar = 0x7,
  kArray = 0x8,
  kRecord = 0x9,
};

// CiA 301 §7.4.7.1 data types: the canopen layer's enum and helpers, named
// here so that EDS users need not know which layer they live in.
using DataType = canopen::DataType;
using canopen::bit_size;
using canopen::is_real;
using canopen::is_signed_integer;
using canopen::is_unsigned_integer;
using canopen::to_string;

// CiA 306 §4.6.3 AccessType values.
enum class AccessType : std::uint8_t { kRo, kWo, kRw, kRwr, kRww, kConst };

// Which object list of the file names the object (CiA 306 §4.5).
enum class ObjectList : std::uint8_t { kMandatory, kOptional, kManufacturer };

[[nodiscard]] std::string_view to_string(AccessType type) noexcept; // "rw"

// A DefaultValue, LowLimit or HighLimit as written in the file.
struct EdsValue {
  enum class Kind : std::uint8_t { kNone, kInteger, kReal, kText };
  Kind kind = Kind::kNone;
  // Two's-complement bit pattern, truncated to the data type's width.
  std::uint64_t integer = 0;
  // "$NODEID+..." (CiA 306 §4.6.3): the node-ID is added when resolved.
  bool plus_node_id = false;
  double real = 0.0;
  // The text after '=' (trimmed); the value itself for string types.
  std::string text;
};

// One addressable entry (index, sub-index) of the object dictionary: a VAR
// object (sub 0) or one sub-object of an ARRAY/RECORD.
struct ObjectDesc {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::string name;  // ParameterName
  DataType data_type = DataType::kUnsigned8;
  AccessType access = AccessType::kRo;
  bool pdo_mapping = false;
  EdsValue default_value;
  EdsValue low_limit;
  EdsValue high_limit;
  std::size_t line = 0;  // line of the section header, for diagnostics

  [[nodiscard]] std::uint32_t bits() const noexcept { return bit_size(data_type); }
  // DefaultValue as a bit pattern with `node_id` added for $NODEID forms;
  // nullopt if there is no numeric default.
  [[nodiscard]] std::optional<std::uint64_t> default_for_node(std::uint8_t node_id) const noexcept;
  // The same, sign-extended for signed integer types.
  [[nodiscard]] std::optional<std::int64_t> default_signed_for_node(std::uint8_t node_id) const noexcept;
};

// One object section [XXXX]: its header data; the addressable entries are
// ObjectDescs (for a VAR, one entry with sub 0).
struct ObjectEntry {
  std::uint16_t index = 0;
  std::string name;
  ObjectType type = ObjectType::kVar;
  std::uint8_t sub_number = 0;  // SubNumber (ARRAY/RECORD)
  ObjectList list = ObjectList::kOptional;
  std::size_t line = 0;
};

struct FileInfo {
  std::string file_name;
  std::uint8_t file_version = 0;
  std::uint8_t file_revision = 0;
  std::string eds_version;
  std::string description;
  std::string creation_date;
  std::string created_by;
};

struct DeviceInfo {
  std::string vendor_name;
  std::uint32_t vendor_number = 0;
  std::string product_name;
  std::uint32_t product_number = 0;
  std::uint32_t revision_number = 0;
  std::string order_code;
  // BaudRate_10 .. BaudRate_1000 in kbit/s (CiA 306 §4.4).
  bool baud_10 = false, baud_20 = false, baud_50 = false, baud_125 = false;
  bool baud_250 = false, baud_500 = false, baud_800 = false, baud_1000 = false;
  bool simple_boot_up_master = false;
  bool simple_boot_up_slave = false;
  std::uint8_t granularity = 0;
  bool dynamic_channels_supported = false;
  bool group_messaging = false;
  std::uint16_t nr_of_rx_pdo = 0;
  std::uint16_t nr_of_tx_pdo = 0;
  bool lss_supported = false;
};

// Optional [Cobridge] section: how the catalog selects this description
// beyond (vendor, product, revision). Ignored by other EDS tools.
struct Selection {
  std::string family;
  std::string variant;  // e.g. "1ch" / "2ch"; empty = the only variant
  // Object whose value tells the variants of one product apart
  // (VariantProbe=0x6020sub0, VariantValue=2).
  std::optional<std::uint16_t> probe_index;
  std::uint8_t probe_sub = 0;
  std::uint64_t probe_value = 0;
  // Product codes that also select this description (e.g. legacy codes).
  std::vector<std::uint32_t> additional_products;
  // Select for any product code of the vendor when no exact match exists
  // (for devices whose product code is not reliably documented).
  bool match_any_product = false;
};

struct DeviceDescription {
  std::string source;  // file the description came from
  FileInfo file_info;
  DeviceInfo device_info;
  Selection selection;
  std::vector<ObjectEntry> objects;  // sorted by index
  std::vector<ObjectDesc> entries;   // sorted by (index, sub)

  [[nodiscard]] const ObjectDesc* find(std::uint16_t index, std::uint8_t sub) const noexcept;
  [[nodiscard]] const ObjectEntry* object(std::uint16_t index) const noexcept;
};

enum class EdsErrc {
  kIo = 1,
  kSyntax,              // not a section header, key=value, or comment
  kBinaryData,          // control characters / NUL bytes
  kDuplicateSection,
  kDuplicateKey,
  kMissingSection,      // named in an object list but absent, or a required section
  kUnlistedObject,      // object section not named in any object list
  kSubWithoutParent,
  kMissingKey,
  kBadNumber,
  kBadDataType,
  kBadObjectType,
  kBadAccessType,
  kOutOfRange,          // value does not fit its type or limits
  kInconsistent,        // counts or identity disagree
  kUnsupported,
  kDuplicateIdentity,   // DeviceCatalog: two files describe the same device
  kTooManyErrors,
};

[[nodiscard]] const std::error_category& eds_category() noexcept;
[[nodiscard]] std::error_code make_error_code(EdsErrc e) noexcept;

struct EdsError {
  std::string file;
  std::size_t line = 0;    // 1-based; 0 = whole file
  std::size_t column = 0;  // 1-based; 0 = not meaningful
  EdsErrc code = EdsErrc::kSyntax;
  std::string message;

  // "file:line:column: message" (line/column left out when 0).
  [[nodiscard]] std::string to_string() const;
  // "file:line:column" (line/column left out when 0).
  [[nodiscard]] std::string where() const;
};

// The project's one error shape: kind kNotFound / kFailed for a file that
// cannot be opened or read (kIo), kInvalidArgument for its contents; the
// EdsErrc as the precise code; where = "file:line:column".
[[nodiscard]] Error to_error(const EdsError& error);

// Either a description or the list of everything wrong with the file.
struct EdsResult {
  std::optional<DeviceDescription> description;
  std::vector<EdsError> errors;
  [[nodiscard]] bool ok() const noexcept { return description.has_value(); }
};

// Parses EDS text; `file_name` is only used in error messages and `source`.
[[nodiscard]] EdsResult parse_eds(std::string_view text, std::string_view file_name) noexcept;
// Reads and parses a file (at most 4 MiB).
[[nodiscard]] EdsResult load_eds_file(const std::filesystem::path& path) noexcept;

}  // namespace cobridge::device

namespace std {
template <>
struct is_error_code_enum<cobridge::device::EdsErrc> : true_type {};
}  // namespace std
