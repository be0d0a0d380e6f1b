#include "canopen/object_dictionary.hpp"

#include <algorithm>
#include <bit>
#include <cstring>
#include <limits>
#include <utility>

namespace cobridge::canopen {

namespace {

// Size in bytes of a numeric type the dictionary stores; 0 for strings and
// for the types it does not store (TIME_OF_DAY, TIME_DIFFERENCE).
constexpr unsigned width_of(DataType t) noexcept {
  if (t == DataType::kBoolean) return 1;  // one bit in CiA 301, but SDO carries and we store a byte
  if (!is_signed_integer(t) && !is_unsigned_integer(t) && !is_real(t)) return 0;
  return bit_size(t) / 8U;
}

constexpr uint64_t mask_of(unsigned width) noexcept {
  return width >= 8 ? ~uint64_t{0} : (uint64_t{1} << (8U * width)) - 1U;
}

constexpr int64_t sign_extend(uint64_t raw, unsigned width) noexcept {
  const unsigned shift = 64U - 8U * width;
  // C++20 defines >> on negative values as arithmetic.
  return static_cast<int64_t>(raw << shift) >> shift;
}

constexpr int64_t signed_max(unsigned width) noexcept {
  return static_cast<int64_t>(mask_of(width) >> 1U);
}
constexpr int64_t signed_min(unsigned width) noexcept { return -signed_max(width) - 1; }

uint64_t load_le(std::span<const uint8_t> data) noexcept {
  uint64_t v = 0;
  for (size_t i = data.size(); i-- > 0;) v = (v << 8U) | data[i];
  return v;
}

void store_le(uint64_t v, std::span<uint8_t> out) noexcept {
  for (auto& b : out) {
    b = static_cast<uint8_t>(v & 0xFFU);
    v >>= 8U;
  }
}

double real_of(uint64_t raw, DataType t) noexcept {
  if (t == DataType::kReal32) return static_cast<double>(std::bit_cast<float>(static_cast<uint32_t>(raw)));
  return std::bit_cast<double>(raw);
}

class OdCategory final : public std::error_category {
 public:
  [[nodiscard]] const char* name() const noexcept override { return "cobridge.object_dictionary"; }
  [[nodiscard]] std::string message(int ev) const override {
    switch (static_cast<OdError>(ev)) {
      case OdError::kDuplicateEntry: return "object dictionary entry already exists";
      case OdError::kUnsupportedType: return "data type not supported by the object dictionary";
      case OdError::kValueDoesNotFit: return "value or limit does not fit the entry's data type";
      case OdError::kBadLimits: return "low limit above high limit, or default outside the limits";
      case OdError::kStringTooLong: return "initial string longer than its capacity";
      case OdError::kNoSuchEntry: return "no such object dictionary entry";
    }
    return "unknown object dictionary error";
  }
};

}  // namespace

const std::error_category& od_category() noexcept {
  static const OdCategory category;
  return category;
}

std::error_code make_error_code(OdError e) noexcept { return {static_cast<int>(e), od_category()}; }

int64_t WriteRequest::as_signed() const noexcept {
  const unsigned w = width_of(type);
  return w == 0 ? 0 : sign_extend(raw, w);
}

float WriteRequest::as_real32() const noexcept {
  return std::bit_cast<float>(static_cast<uint32_t>(raw));
}

ObjectDictionary::ObjectDictionary(Options options) : options_(options) {}

ObjectDictionary::Kind ObjectDictionary::kind_of(DataType t) noexcept {
  if (is_unsigned_integer(t)) return Kind::kUnsigned;
  if (is_signed_integer(t)) return Kind::kSigned;
  if (is_real(t)) return Kind::kReal;
  return Kind::kString;
}

namespace {

// Converts a setup-time Number into the entry's raw representation, or
// nullopt when it does not fit (no silent truncation of defaults or limits).
std::optional<uint64_t> to_raw(const Number& n, DataType t, unsigned width, bool is_signed, bool is_real) {
  if (is_real) {
    double d = 0.0;
    switch (n.kind()) {
      case Number::Kind::kReal: d = n.as_real(); break;
      case Number::Kind::kSigned: d = static_cast<double>(n.as_signed()); break;
      case Number::Kind::kUnsigned: d = static_cast<double>(n.as_unsigned()); break;
    }
    if (t == DataType::kReal32) return std::bit_cast<uint32_t>(static_cast<float>(d));
    return std::bit_cast<uint64_t>(d);
  }
  if (n.kind() == Number::Kind::kReal) return std::nullopt;
  if (is_signed) {
    int64_t v = 0;
    if (n.kind() == Number::Kind::kUnsigned) {
      if (n.as_unsigned() > static_cast<uint64_t>(signed_max(width))) return std::nullopt;
      v = static_cast<int64_t>(n.as_unsigned());
    } else {
      v = n.as_signed();
    }
    if (v < signed_min(width) || v > signed_max(width)) return std::nullopt;
    return static_cast<uint64_t>(v) & mask_of(width);
  }
  uint64_t u = 0;
  if (n.kind() == Number::Kind::kSigned) {
    if (n.as_signed() < 0) return std::nullopt;
    u = static_cast<uint64_t>(n.as_signed());
  } else {
    u = n.as_unsigned();
  }
  const uint64_t max = t == DataType::kBoolean ? 1U : mask_of(width);
  if (u > max) return std::nullopt;
  return u;
}

// -1, 0, +1 comparing two raw values of the same numeric type.
int compare_raw(uint64_t a, uint64_t b, DataType t, unsigned width, bool is_signed, bool is_real) noexcept {
  if (is_real) {
    const double x = real_of(a, t);
    const double y = real_of(b, t);
    return x < y ? -1 : (x > y ? 1 : 0);
  }
  if (is_signed) {
    const int64_t x = sign_extend(a, width);
    const int64_t y = sign_extend(b, width);
    return x < y ? -1 : (x > y ? 1 : 0);
  }
  return a < b ? -1 : (a > b ? 1 : 0);
}

// Whether `t` is one of the enum's values (a cast may produce others).
constexpr bool listed_type(DataType t) noexcept {
  switch (t) {
    case DataType::kBoolean: case DataType::kInteger8: case DataType::kInteger16:
    case DataType::kInteger32: case DataType::kUnsigned8: case DataType::kUnsigned16:
    case DataType::kUnsigned32: case DataType::kReal32: case DataType::kVisibleString:
    case DataType::kOctetString: case DataType::kDomain: case DataType::kInteger24:
    case DataType::kReal64: case DataType::kInteger40: case DataType::kInteger48:
    case DataType::kInteger56: case DataType::kInteger64: case DataType::kUnsigned24:
    case DataType::kUnsigned40: case DataType::kUnsigned48: case DataType::kUnsigned56:
    case DataType::kUnsigned64:
      return true;
    default:
      return false;
  }
}

constexpr uint32_t make_key(uint16_t index, uint8_t sub) noexcept {
  return (static_cast<uint32_t>(index) << 8U) | sub;
}

}  // namespace

std::error_code ObjectDictionary::insert(const EntryDef& def) {
  const Kind kind = kind_of(def.type);
  const unsigned width = width_of(def.type);
  if (kind != Kind::kString && width == 0) return OdError::kUnsupportedType;
  if (!listed_type(def.type)) return OdError::kUnsupportedType;

  const uint32_t key = make_key(def.index, def.sub);
  auto pos = std::lower_bound(entries_.begin(), entries_.end(), key,
                              [](const Entry& e, uint32_t k) { return e.key < k; });
  if (pos != entries_.end() && pos->key == key) return OdError::kDuplicateEntry;

  Entry e;
  e.key = key;
  e.type = def.type;
  e.access = def.access;
  e.pdo_mappable = def.pdo_mappable;
  e.name = std::string(def.name);
  const std::error_code ec = kind == Kind::kString ? store_text(e, def) : store_number(e, def, width, kind);
  if (ec) return ec;
  entries_.insert(pos, std::move(e));
  return {};
}

// A string entry gets its capacity in pool_ now, so that writes never
// allocate.
std::error_code ObjectDictionary::store_text(Entry& e, const EntryDef& def) {
  if (def.capacity != 0 && def.text.size() > def.capacity) return OdError::kStringTooLong;
  const size_t capacity = def.capacity != 0 ? def.capacity : def.text.size();
  if (capacity > std::numeric_limits<uint32_t>::max() - pool_.size()) return OdError::kStringTooLong;
  e.offset = static_cast<uint32_t>(pool_.size());
  e.capacity = static_cast<uint32_t>(capacity);
  e.length = static_cast<uint32_t>(def.text.size());
  pool_.resize(pool_.size() + capacity, 0);
  if (!def.text.empty()) std::memcpy(pool_.data() + e.offset, def.text.data(), def.text.size());
  max_value_size_ = std::max(max_value_size_, capacity);
  return {};
}

// A number entry: its value and limits as raw bytes of its type, the value
// within the limits.
std::error_code ObjectDictionary::store_number(Entry& e, const EntryDef& def, unsigned width, Kind kind) {
  const bool is_signed = kind == Kind::kSigned;
  const bool is_real = kind == Kind::kReal;
  e.width = static_cast<uint8_t>(width);
  const auto value = to_raw(def.value, def.type, width, is_signed, is_real);
  if (!value) return OdError::kValueDoesNotFit;
  e.value = *value;
  if (def.low) {
    const auto low = to_raw(*def.low, def.type, width, is_signed, is_real);
    if (!low) return OdError::kValueDoesNotFit;
    e.low = *low;
    e.has_low = true;
  }
  if (def.high) {
    const auto high = to_raw(*def.high, def.type, width, is_signed, is_real);
    if (!high) return OdError::kValueDoesNotFit;
    e.high = *high;
    e.has_high = true;
  }
  if (e.has_low && e.has_high && compare_raw(e.low, e.high, e.type, width, is_signed, is_real) > 0)
    return OdError::kBadLimits;
  if (check_range(e, e.value) != od_abort::kNone) return OdError::kBadLimits;
  max_value_size_ = std::max<size_t>(max_value_size_, width);
  return {};
}

std::error_code ObjectDictionary::set_hooks(uint16_t index, uint8_t sub, Hooks hooks) {
  Entry* e = find(index, sub);
  if (e == nullptr) return OdError::kNoSuchEntry;
  hooks_.push_back(std::move(hooks));
  e->hooks = static_cast<uint16_t>(hooks_.size() - 1);
  return {};
}

std::error_code ObjectDictionary::set_hooks(uint16_t index, Hooks hooks) {
  if (!contains_index(index)) return OdError::kNoSuchEntry;
  hooks_.push_back(std::move(hooks));
  const auto slot = static_cast<uint16_t>(hooks_.size() - 1);
  for (auto& e : entries_)
    if ((e.key >> 8U) == index) e.hooks = slot;
  return {};
}

const ObjectDictionary::Entry* ObjectDictionary::find(uint16_t index, uint8_t sub) const noexcept {
  const uint32_t key = make_key(index, sub);
  auto pos = std::lower_bound(entries_.begin(), entries_.end(), key,
                              [](const Entry& e, uint32_t k) { return e.key < k; });
  return (pos != entries_.end() && pos->key == key) ? &*pos : nullptr;
}

ObjectDictionary::Entry* ObjectDictionary::find(uint16_t index, uint8_t sub) noexcept {
  return const_cast<Entry*>(std::as_const(*this).find(index, sub));
}

bool ObjectDictionary::contains(uint16_t index, uint8_t sub) const noexcept {
  return find(index, sub) != nullptr;
}

bool ObjectDictionary::contains_index(uint16_t index) const noexcept {
  const uint32_t key = make_key(index, 0);
  auto pos = std::lower_bound(entries_.begin(), entries_.end(), key,
                              [](const Entry& e, uint32_t k) { return e.key < k; });
  return pos != entries_.end() && (pos->key >> 8U) == index;
}

std::optional<EntryInfo> ObjectDictionary::info(uint16_t index, uint8_t sub) const noexcept {
  const Entry* e = find(index, sub);
  if (e == nullptr) return std::nullopt;
  EntryInfo i;
  i.index = index;
  i.sub = sub;
  i.type = e->type;
  i.access = e->access;
  i.pdo_mappable = e->pdo_mappable;
  i.is_string = kind_of(e->type) == Kind::kString;
  i.size = i.is_string ? e->length : e->width;
  i.capacity = i.is_string ? e->capacity : e->width;
  i.name = e->name;
  return i;
}

uint32_t ObjectDictionary::missing_code(uint16_t index) const noexcept {
  return contains_index(index) ? od_abort::kSubIndexDoesNotExist : od_abort::kObjectDoesNotExist;
}

uint32_t ObjectDictionary::check_range(const Entry& e, uint64_t raw) const noexcept {
  const Kind kind = kind_of(e.type);
  const bool is_signed = kind == Kind::kSigned;
  const bool is_real = kind == Kind::kReal;
  const bool too_low = e.has_low && compare_raw(raw, e.low, e.type, e.width, is_signed, is_real) < 0;
  // BOOLEAN carries an implicit range of 0..1.
  const bool too_high = (e.has_high && compare_raw(raw, e.high, e.type, e.width, is_signed, is_real) > 0) ||
                        (e.type == DataType::kBoolean && raw > 1U);
  if (!too_low && !too_high) return od_abort::kNone;
  if (!options_.specific_range_aborts) return od_abort::kValueRangeExceeded;
  return too_high ? od_abort::kValueTooHigh : od_abort::kValueTooLow;
}

ReadResult ObjectDictionary::read(uint16_t index, uint8_t sub, std::span<uint8_t> out) {
  Entry* e = find(index, sub);
  if (e == nullptr) return {missing_code(index), 0};
  if (e->access == Access::kWo) return {od_abort::kReadOfWriteOnly, 0};
  if (e->hooks != kNoHooks) {
    const Hooks& h = hooks_[e->hooks];
    if (h.on_read) {
      const uint32_t veto = h.on_read(index, sub);
      if (veto != od_abort::kNone) return {veto, 0};
    }
  }
  const bool is_string = kind_of(e->type) == Kind::kString;
  const size_t size = is_string ? e->length : e->width;
  if (out.size() < size) return {od_abort::kOutOfMemory, 0};
  if (is_string) {
    if (size != 0) std::memcpy(out.data(), pool_.data() + e->offset, size);
  } else {
    store_le(e->value, out.first(size));
  }
  return {od_abort::kNone, size};
}

uint32_t ObjectDictionary::check_writable(uint16_t index, uint8_t sub) const noexcept {
  const Entry* e = find(index, sub);
  if (e == nullptr) return missing_code(index);
  if (e->access == Access::kRo || e->access == Access::kConst) return od_abort::kWriteOfReadOnly;
  return od_abort::kNone;
}

uint32_t ObjectDictionary::write(uint16_t index, uint8_t sub, std::span<const uint8_t> data) {
  Entry* e = find(index, sub);
  if (e == nullptr) return missing_code(index);
  if (e->access == Access::kRo || e->access == Access::kConst) return od_abort::kWriteOfReadOnly;

  WriteRequest req;
  req.index = index;
  req.sub = sub;
  req.type = e->type;
  req.data = data;
  const bool is_string = kind_of(e->type) == Kind::kString;
  if (is_string) {
    if (data.size() > e->capacity) return od_abort::kLengthTooHigh;
  } else {
    if (data.size() > e->width) return od_abort::kLengthTooHigh;
    if (data.size() < e->width) return od_abort::kLengthTooLow;
    req.raw = load_le(data);
    const uint32_t range = check_range(*e, req.raw);
    if (range != od_abort::kNone) return range;
  }

  // Hooks must not insert entries (that would move *e); they may use the
  // typed setters freely.
  const Hooks* h = e->hooks != kNoHooks ? &hooks_[e->hooks] : nullptr;
  if (h != nullptr && h->on_write) {
    const uint32_t veto = h->on_write(req);
    if (veto != od_abort::kNone) return veto;
  }
  if (is_string) {
    if (!data.empty()) std::memcpy(pool_.data() + e->offset, data.data(), data.size());
    e->length = static_cast<uint32_t>(data.size());
  } else {
    e->value = req.raw;
  }
  if (h != nullptr && h->after_write) h->after_write(index, sub);
  return od_abort::kNone;
}

// --- typed accessors ---------------------------------------------------------

std::optional<uint64_t> ObjectDictionary::get_unsigned(uint16_t index, uint8_t sub,
                                                       unsigned max_width) const noexcept {
  const Entry* e = find(index, sub);
  if (e == nullptr || kind_of(e->type) != Kind::kUnsigned || e->width > max_width) return std::nullopt;
  return e->value;
}

std::optional<int64_t> ObjectDictionary::get_signed(uint16_t index, uint8_t sub,
                                                    unsigned max_width) const noexcept {
  const Entry* e = find(index, sub);
  if (e == nullptr || kind_of(e->type) != Kind::kSigned || e->width > max_width) return std::nullopt;
  return sign_extend(e->value, e->width);
}

std::optional<bool> ObjectDictionary::get_bool(uint16_t index, uint8_t sub) const noexcept {
  const Entry* e = find(index, sub);
  if (e == nullptr || e->type != DataType::kBoolean) return std::nullopt;
  return e->value != 0;
}

std::optional<uint8_t> ObjectDictionary::get_u8(uint16_t index, uint8_t sub) const noexcept {
  const auto v = get_unsigned(index, sub, 1);
  return v ? std::optional<uint8_t>(static_cast<uint8_t>(*v)) : std::nullopt;
}
std::optional<uint16_t> ObjectDictionary::get_u16(uint16_t index, uint8_t sub) const noexcept {
  const auto v = get_unsigned(index, sub, 2);
  return v ? std::optional<uint16_t>(static_cast<uint16_t>(*v)) : std::nullopt;
}
std::optional<uint32_t> ObjectDictionary::get_u32(uint16_t index, uint8_t sub) const noexcept {
  const auto v = get_unsigned(index, sub, 4);
  return v ? std::optional<uint32_t>(static_cast<uint32_t>(*v)) : std::nullopt;
}
std::optional<uint64_t> ObjectDictionary::get_u64(uint16_t index, uint8_t sub) const noexcept {
  return get_unsigned(index, sub, 8);
}
std::optional<int8_t> ObjectDictionary::get_i8(uint16_t index, uint8_t sub) const noexcept {
  const auto v = get_signed(index, sub, 1);
  return v ? std::optional<int8_t>(static_cast<int8_t>(*v)) : std::nullopt;
}
std::optional<int16_t> ObjectDictionary::get_i16(uint16_t index, uint8_t sub) const noexcept {
  const auto v = get_signed(index, sub, 2);
  return v ? std::optional<int16_t>(static_cast<int16_t>(*v)) : std::nullopt;
}
std::optional<int32_t> ObjectDictionary::get_i32(uint16_t index, uint8_t sub) const noexcept {
  const auto v = get_signed(index, sub, 4);
  return v ? std::optional<int32_t>(static_cast<int32_t>(*v)) : std::nullopt;
}
std::optional<int64_t> ObjectDictionary::get_i64(uint16_t index, uint8_t sub) const noexcept {
  return get_signed(index, sub, 8);
}
std::optional<float> ObjectDictionary::get_f32(uint16_t index, uint8_t sub) const noexcept {
  const Entry* e = find(index, sub);
  if (e == nullptr || e->type != DataType::kReal32) return std::nullopt;
  return std::bit_cast<float>(static_cast<uint32_t>(e->value));
}
std::optional<std::string_view> ObjectDictionary::get_string(uint16_t index, uint8_t sub) const noexcept {
  const Entry* e = find(index, sub);
  if (e == nullptr || kind_of(e->type) != Kind::kString) return std::nullopt;
  return std::string_view(reinterpret_cast<const char*>(pool_.data() + e->offset), e->length);
}
std::optional<uint64_t> ObjectDictionary::get_raw(uint16_t index, uint8_t sub) const noexcept {
  const Entry* e = find(index, sub);
  if (e == nullptr || kind_of(e->type) == Kind::kString) return std::nullopt;
  return e->value;
}

uint32_t ObjectDictionary::set_unsigned(uint16_t index, uint8_t sub, uint64_t v) noexcept {
  Entry* e = find(index, sub);
  if (e == nullptr) return missing_code(index);
  if (kind_of(e->type) != Kind::kUnsigned) return od_abort::kLengthMismatch;
  const uint64_t max = e->type == DataType::kBoolean ? 1U : mask_of(e->width);
  if (v > max) return od_abort::kValueRangeExceeded;
  e->value = v;
  return od_abort::kNone;
}

uint32_t ObjectDictionary::set_signed(uint16_t index, uint8_t sub, int64_t v) noexcept {
  Entry* e = find(index, sub);
  if (e == nullptr) return missing_code(index);
  if (kind_of(e->type) != Kind::kSigned) return od_abort::kLengthMismatch;
  if (v < signed_min(e->width) || v > signed_max(e->width)) return od_abort::kValueRangeExceeded;
  e->value = static_cast<uint64_t>(v) & mask_of(e->width);
  return od_abort::kNone;
}

uint32_t ObjectDictionary::set_bool(uint16_t index, uint8_t sub, bool v) noexcept {
  Entry* e = find(index, sub);
  if (e == nullptr) return missing_code(index);
  if (e->type != DataType::kBoolean) return od_abort::kLengthMismatch;
  e->value = v ? 1U : 0U;
  return od_abort::kNone;
}
uint32_t ObjectDictionary::set_u8(uint16_t index, uint8_t sub, uint8_t v) noexcept {
  return set_unsigned(index, sub, v);
}
uint32_t ObjectDictionary::set_u16(uint16_t index, uint8_t sub, uint16_t v) noexcept {
  return set_unsigned(index, sub, v);
}
uint32_t ObjectDictionary::set_u32(uint16_t index, uint8_t sub, uint32_t v) noexcept {
  return set_unsigned(index, sub, v);
}
uint32_t ObjectDictionary::set_u64(uint16_t index, uint8_t sub, uint64_t v) noexcept {
  return set_unsigned(index, sub, v);
}
uint32_t ObjectDictionary::set_i8(uint16_t index, uint8_t sub, int8_t v) noexcept {
  return set_signed(index, sub, v);
}
uint32_t ObjectDictionary::set_i16(uint16_t index, uint8_t sub, int16_t v) noexcept {
  return set_signed(index, sub, v);
}
uint32_t ObjectDictionary::set_i32(uint16_t index, uint8_t sub, int32_t v) noexcept {
  return set_signed(index, sub, v);
}
uint32_t ObjectDictionary::set_i64(uint16_t index, uint8_t sub, int64_t v) noexcept {
  return set_signed(index, sub, v);
}
uint32_t ObjectDictionary::set_f32(uint16_t index, uint8_t sub, float v) noexcept {
  Entry* e = find(index, sub);
  if (e == nullptr) return missing_code(index);
  if (e->type != DataType::kReal32) return od_abort::kLengthMismatch;
  e->value = std::bit_cast<uint32_t>(v);
  return od_abort::kNone;
}
uint32_t ObjectDictionary::set_string(uint16_t index, uint8_t sub, std::string_view v) noexcept {
  Entry* e = find(index, sub);
  if (e == nullptr) return missing_code(index);
  if (kind_of(e->type) != Kind::kString) return od_abort::kLengthMismatch;
  if (v.size() > e->capacity) return od_abort::kLengthTooHigh;
  if (!v.empty()) std::memcpy(pool_.data() + e->offset, v.data(), v.size());
  e->length = static_cast<uint32_t>(v.size());
  return od_abort::kNone;
}

}  // namespace cobridge::canopen
