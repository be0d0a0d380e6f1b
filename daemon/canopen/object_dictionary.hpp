// ObjectDictionary: the CiA 301 object dictionary of one simulated device.
//
// Entries are addressed by (index, sub-index) and carry a CiA 301 data type,
// an access attribute, a PDO-mappable flag, optional value limits, a value and
// a name. The table is built at setup (insert in any order; it is kept sorted)
// and afterwards every lookup is a binary search; reading and writing numeric
// values never allocates. Strings get a fixed capacity at insert time.
//
// Two ways in:
//   * read()/write() are the SDO server's path. They apply the CiA 301 checks
//     (existence, access, length, limits) and then the owner's hooks, and they
//     answer with a CiA 301 SDO abort code (0 = success).
//   * the typed accessors (get_u32/set_u32, ...) are the device model's path.
//     They bypass access rights, limits and hooks, because the device model
//     owns the values (it must be able to update a read-only position), but
//     they still check that the entry exists and the C++ type fits the
//     CiA 301 type.
//
// Thread: not synchronised. Everything (setup, the device model, the SDO
// server, hooks) runs on the thread that drives the simulated device.
#pragma once

#include <concepts>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <vector>

#include "canopen/data_type.hpp"

namespace cobridge::canopen {

// --- SDO abort codes (CiA 301 §7.2.4.3.17, table "SDO abort codes") --------
// Temporary raw values: the project's `SdoAbort` enum (sdo_abort.hpp) is being
// written in parallel; these names will be replaced by it at integration.
// Hooks return one of these (or any other CiA 301 code); 0 means success.
namespace od_abort {
inline constexpr uint32_t kNone = 0;
inline constexpr uint32_t kToggleBitNotAlternated = 0x05030000;
inline constexpr uint32_t kSdoProtocolTimedOut = 0x05040000;
inline constexpr uint32_t kCommandSpecifierInvalid = 0x05040001;
inline constexpr uint32_t kOutOfMemory = 0x05040005;
inline constexpr uint32_t kUnsupportedAccess = 0x06010000;
inline constexpr uint32_t kReadOfWriteOnly = 0x06010001;
inline constexpr uint32_t kWriteOfReadOnly = 0x06010002;
inline constexpr uint32_t kObjectDoesNotExist = 0x06020000;
inline constexpr uint32_t kAccessError = 0x06060000;  // "hardware error" in CiA 301; "access error" in J§1.6.3/E§7.3
inline constexpr uint32_t kLengthMismatch = 0x06070010;
inline constexpr uint32_t kLengthTooHigh = 0x06070012;
inline constexpr uint32_t kLengthTooLow = 0x06070013;
inline constexpr uint32_t kSubIndexDoesNotExist = 0x06090011;
inline constexpr uint32_t kValueRangeExceeded = 0x06090030;
inline constexpr uint32_t kValueTooHigh = 0x06090031;
inline constexpr uint32_t kValueTooLow = 0x06090032;
inline constexpr uint32_t kGeneralError = 0x08000000;
inline constexpr uint32_t kCannotStore = 0x08000020;
inline constexpr uint32_t kCannotStoreLocalControl = 0x08000021;
inline constexpr uint32_t kCannotStoreDeviceState = 0x08000022;  // "wrong state" in J§1.6.3/E§7.3
}  // namespace od_abort

// Access attribute as written in EDS files and the manuals' tables. `kConst`
// behaves like `kRo` for SDO; the distinction matters to EDS and to 'restore'.
enum class Access : uint8_t { kRo, kWo, kRw, kConst };

// Setup-time errors (insert, set_hooks). Never produced on the read/write path.
enum class OdError {
  kDuplicateEntry = 1,   // (index, sub) already present
  kUnsupportedType,      // a CiA 301 type this dictionary does not store
  kValueDoesNotFit,      // default or limit does not fit the data type
  kBadLimits,            // low > high, or the default lies outside the limits
  kStringTooLong,        // initial string longer than the capacity
  kNoSuchEntry,          // set_hooks on an entry/index that does not exist
};
[[nodiscard]] const std::error_category& od_category() noexcept;
[[nodiscard]] std::error_code make_error_code(OdError e) noexcept;

// A number as the caller spells it (signed, unsigned or real); converted to
// the entry's data type at insert, where a value that does not fit is
// rejected rather than silently truncated.
class Number {
 public:
  enum class Kind : uint8_t { kUnsigned, kSigned, kReal };

  constexpr Number() noexcept = default;
  template <std::integral T>
  constexpr Number(T v) noexcept {  // NOLINT(google-explicit-constructor): literals read naturally
    if constexpr (std::is_signed_v<T>) {
      kind_ = Kind::kSigned;
      i_ = static_cast<int64_t>(v);
    } else {
      kind_ = Kind::kUnsigned;
      u_ = static_cast<uint64_t>(v);
    }
  }
  constexpr Number(double v) noexcept : kind_(Kind::kReal), r_(v) {}  // NOLINT(google-explicit-constructor)
  constexpr Number(float v) noexcept : kind_(Kind::kReal), r_(static_cast<double>(v)) {}  // NOLINT

  [[nodiscard]] constexpr Kind kind() const noexcept { return kind_; }
  [[nodiscard]] constexpr uint64_t as_unsigned() const noexcept { return u_; }
  [[nodiscard]] constexpr int64_t as_signed() const noexcept { return i_; }
  [[nodiscard]] constexpr double as_real() const noexcept { return r_; }

 private:
  Kind kind_ = Kind::kUnsigned;
  uint64_t u_ = 0;
  int64_t i_ = 0;
  double r_ = 0.0;
};

// What insert() takes. Numbers use `value`/`low`/`high`; strings use
// `capacity` (bytes reserved) and `text` (initial content).
struct EntryDef {
  uint16_t index = 0;
  uint8_t sub = 0;
  DataType type = DataType::kUnsigned32;
  Access access = Access::kRw;
  bool pdo_mappable = false;
  std::string_view name{};
  Number value{};
  std::optional<Number> low{};   // inclusive
  std::optional<Number> high{};  // inclusive
  uint32_t capacity = 0;       // strings: bytes reserved (>= text.size())
  std::string_view text{};     // strings: initial content
};

// Read-only view of an entry's metadata.
struct EntryInfo {
  uint16_t index = 0;
  uint8_t sub = 0;
  DataType type = DataType::kUnsigned32;
  Access access = Access::kRw;
  bool pdo_mappable = false;
  bool is_string = false;   // VISIBLE_STRING, OCTET_STRING, DOMAIN
  uint32_t size = 0;        // current size in bytes (numbers: the type's size)
  uint32_t capacity = 0;    // largest size a write may have
  std::string_view name{};
};

// A write as the on_write hook sees it, before it is committed.
struct WriteRequest {
  uint16_t index = 0;
  uint8_t sub = 0;
  DataType type = DataType::kUnsigned32;
  std::span<const uint8_t> data{};  // the bytes as received (little-endian)
  uint64_t raw = 0;               // numbers: `data` zero-extended; strings: 0

  // Numbers only: the value in the entry's own type, widened.
  [[nodiscard]] uint64_t as_unsigned() const noexcept { return raw; }
  [[nodiscard]] int64_t as_signed() const noexcept;
  [[nodiscard]] float as_real32() const noexcept;
};

// Owner callbacks. on_read runs before the value is copied out (so it may
// refresh the value through the typed setters) and may veto with an abort
// code. on_write runs after all CiA 301 checks and before the value is
// stored; a non-zero return vetoes the write and nothing is stored. A hook
// that vetoes must do so before causing side effects. after_write runs once
// the value is stored (e.g. to couple 0x6001 and 0x6002, or to put a signature
// object back to its read value).
struct Hooks {
  std::function<uint32_t(uint16_t index, uint8_t sub)> on_read{};
  std::function<uint32_t(const WriteRequest&)> on_write{};
  std::function<void(uint16_t index, uint8_t sub)> after_write{};
};

struct ReadResult {
  uint32_t abort_code = 0;  // 0 = success
  size_t size = 0;          // bytes written to `out`
};

class ObjectDictionary {
 public:
  struct Options {
    // CiA 301 has a general "value range exceeded" (0x06090030) and the
    // specific "too high"/"too low" (0x06090031/32). The Novotechnik manuals
    // list only 0x06090030 (J§1.6.3, E§7.3), so that is the default.
    bool specific_range_aborts = false;
  };

  ObjectDictionary() : ObjectDictionary(Options{}) {}
  explicit ObjectDictionary(Options options);

  // --- setup ---------------------------------------------------------------
  [[nodiscard]] std::error_code insert(const EntryDef& def);
  // Hooks for one entry, or for every sub-index of an index (entries inserted
  // later are not covered). A later registration replaces an earlier one.
  [[nodiscard]] std::error_code set_hooks(uint16_t index, uint8_t sub, Hooks hooks);
  [[nodiscard]] std::error_code set_hooks(uint16_t index, Hooks hooks);

  // --- inspection ----------------------------------------------------------
  [[nodiscard]] bool contains(uint16_t index, uint8_t sub) const noexcept;
  [[nodiscard]] bool contains_index(uint16_t index) const noexcept;
  [[nodiscard]] std::optional<EntryInfo> info(uint16_t index, uint8_t sub) const noexcept;
  [[nodiscard]] size_t entry_count() const noexcept { return entries_.size(); }
  // The largest value any entry can hold: the SDO server sizes its transfer
  // buffer from it.
  [[nodiscard]] size_t max_value_size() const noexcept { return max_value_size_; }

  // --- SDO path (checks + hooks; return CiA 301 abort codes) ---------------
  [[nodiscard]] ReadResult read(uint16_t index, uint8_t sub, std::span<uint8_t> out);
  [[nodiscard]] uint32_t write(uint16_t index, uint8_t sub, std::span<const uint8_t> data);
  // Existence and access only, for a segmented download's initiate phase.
  [[nodiscard]] uint32_t check_writable(uint16_t index, uint8_t sub) const noexcept;

  // --- device-model path (no access/limit checks, no hooks) ----------------
  // Getters return nullopt when the entry is missing or of another kind or a
  // wider type than the accessor. Setters return 0 or an abort code:
  // 0x06020000/0x06090011 missing, 0x06070010 wrong kind of type,
  // 0x06090030 value does not fit the entry's type, 0x06070012 string too long.
  [[nodiscard]] std::optional<bool> get_bool(uint16_t index, uint8_t sub) const noexcept;
  [[nodiscard]] std::optional<uint8_t> get_u8(uint16_t index, uint8_t sub) const noexcept;
  [[nodiscard]] std::optional<uint16_t> get_u16(uint16_t index, uint8_t sub) const noexcept;
  [[nodiscard]] std::optional<uint32_t> get_u32(uint16_t index, uint8_t sub) const noexcept;
  [[nodiscard]] std::optional<uint64_t> get_u64(uint16_t index, uint8_t sub) const noexcept;
  [[nodiscard]] std::optional<int8_t> get_i8(uint16_t index, uint8_t sub) const noexcept;
  [[nodiscard]] std::optional<int16_t> get_i16(uint16_t index, uint8_t sub) const noexcept;
  [[nodiscard]] std::optional<int32_t> get_i32(uint16_t index, uint8_t sub) const noexcept;
  [[nodiscard]] std::optional<int64_t> get_i64(uint16_t index, uint8_t sub) const noexcept;
  [[nodiscard]] std::optional<float> get_f32(uint16_t index, uint8_t sub) const noexcept;
  // The view stays valid until the string is next written.
  [[nodiscard]] std::optional<std::string_view> get_string(uint16_t index, uint8_t sub) const noexcept;
  // Numbers of any type: the little-endian bytes zero-extended (PDO packing).
  [[nodiscard]] std::optional<uint64_t> get_raw(uint16_t index, uint8_t sub) const noexcept;

  [[nodiscard]] uint32_t set_bool(uint16_t index, uint8_t sub, bool v) noexcept;
  [[nodiscard]] uint32_t set_u8(uint16_t index, uint8_t sub, uint8_t v) noexcept;
  [[nodiscard]] uint32_t set_u16(uint16_t index, uint8_t sub, uint16_t v) noexcept;
  [[nodiscard]] uint32_t set_u32(uint16_t index, uint8_t sub, uint32_t v) noexcept;
  [[nodiscard]] uint32_t set_u64(uint16_t index, uint8_t sub, uint64_t v) noexcept;
  [[nodiscard]] uint32_t set_i8(uint16_t index, uint8_t sub, int8_t v) noexcept;
  [[nodiscard]] uint32_t set_i16(uint16_t index, uint8_t sub, int16_t v) noexcept;
  [[nodiscard]] uint32_t set_i32(uint16_t index, uint8_t sub, int32_t v) noexcept;
  [[nodiscard]] uint32_t set_i64(uint16_t index, uint8_t sub, int64_t v) noexcept;
  [[nodiscard]] uint32_t set_f32(uint16_t index, uint8_t sub, float v) noexcept;
  [[nodiscard]] uint32_t set_string(uint16_t index, uint8_t sub, std::string_view v) noexcept;

 private:
  static constexpr uint16_t kNoHooks = 0xFFFF;

  struct Entry {
    uint32_t key = 0;  // index << 8 | sub: the sort key
    DataType type = DataType::kUnsigned32;
    Access access = Access::kRw;
    bool pdo_mappable = false;
    bool has_low = false;
    bool has_high = false;
    uint16_t hooks = kNoHooks;  // slot in hooks_
    uint8_t width = 0;          // numbers: bytes; strings: 0
    uint64_t value = 0;         // numbers: little-endian bytes zero-extended
    uint64_t low = 0;
    uint64_t high = 0;
    uint32_t offset = 0;    // strings: start in pool_
    uint32_t capacity = 0;  // strings
    uint32_t length = 0;    // strings: current size
    std::string name;
  };
  enum class Kind : uint8_t { kUnsigned, kSigned, kReal, kString };

  [[nodiscard]] const Entry* find(uint16_t index, uint8_t sub) const noexcept;
  [[nodiscard]] Entry* find(uint16_t index, uint8_t sub) noexcept;
  [[nodiscard]] uint32_t missing_code(uint16_t index) const noexcept;
  [[nodiscard]] uint32_t check_range(const Entry& e, uint64_t raw) const noexcept;
  [[nodiscard]] std::optional<uint64_t> get_unsigned(uint16_t index, uint8_t sub, unsigned max_width) const noexcept;
  [[nodiscard]] std::optional<int64_t> get_signed(uint16_t index, uint8_t sub, unsigned max_width) const noexcept;
  [[nodiscard]] uint32_t set_unsigned(uint16_t index, uint8_t sub, uint64_t v) noexcept;
  [[nodiscard]] uint32_t set_signed(uint16_t index, uint8_t sub, int64_t v) noexcept;
  [[nodiscard]] static Kind kind_of(DataType t) noexcept;
  std::error_code store_text(Entry& e, const EntryDef& def);
  std::error_code store_number(Entry& e, const EntryDef& def, unsigned width, Kind kind);

  Options options_;
  std::vector<Entry> entries_;  // sorted by key
  std::vector<uint8_t> pool_;   // string storage
  std::vector<Hooks> hooks_;
  size_t max_value_size_ = 0;
};

}  // namespace cobridge::canopen

template <>
struct std::is_error_code_enum<cobridge::canopen::OdError> : std::true_type {};
