#include "app/truth_writer.hpp"

#include <cerrno>
#include <cstring>

namespace cobridge::sim {

namespace {

// A bounded appender; every put stops silently at the end of the buffer
// (a line never reaches that: kMaxLineBytes is far above the longest line).
struct Out {
  char* p;
  char* end;
  void put(char c) noexcept {
    if (p < end) *p++ = c;
  }
  void put(std::string_view s) noexcept {
    for (const char c : s) put(c);
  }
  void dec(std::uint64_t v) noexcept {
    char tmp[20];
    std::size_t n = 0;
    do {
      tmp[n++] = static_cast<char>('0' + v % 10);
      v /= 10;
    } while (v != 0);
    while (n > 0) put(tmp[--n]);
  }
  void sdec(std::int64_t v) noexcept {
    if (v < 0) {
      put('-');
      dec(static_cast<std::uint64_t>(-(v + 1)) + 1);  // no overflow at INT64_MIN
    } else {
      dec(static_cast<std::uint64_t>(v));
    }
  }
  void hex(std::uint64_t v, int min_digits) noexcept {
    static constexpr char kDigits[] = "0123456789ABCDEF";
    char tmp[16];
    int n = 0;
    do {
      tmp[n++] = kDigits[v & 0xF];
      v >>= 4;
    } while (v != 0 && n < 16);
    while (n < min_digits) tmp[n++] = '0';
    while (n > 0) put(tmp[--n]);
  }
};

}  // namespace

TruthWriter::~TruthWriter() {
  flush();
  if (owned_ && file_ != nullptr) std::fclose(file_);
}

Error TruthWriter::open(const char* path) {
  std::FILE* f = std::fopen(path, "w");
  if (f == nullptr) {
    const std::error_code ec(errno, std::generic_category());
    return Error(Errc::kFailed, ec.message(), path, ec);
  }
  if (owned_ && file_ != nullptr) std::fclose(file_);
  file_ = f;
  owned_ = true;
  return {};
}

void TruthWriter::attach(std::FILE* stream) noexcept {
  file_ = stream;
  owned_ = false;
}

std::string_view TruthWriter::kind_name(const TruthRecord& r) noexcept {
  switch (r.kind) {
    case TruthRecord::Kind::tpdo: return r.pdo == 2 ? "tpdo2" : "tpdo1";
    case TruthRecord::Kind::emcy: return "emcy";
    case TruthRecord::Kind::heartbeat: return "heartbeat";
    case TruthRecord::Kind::boot_up: return "boot-up";
    case TruthRecord::Kind::sdo: return "sdo";
    case TruthRecord::Kind::lss: return "lss";
    case TruthRecord::Kind::guard: return "guard";
  }
  return "other";
}

std::size_t TruthWriter::format(std::string_view iface, const TruthRecord& r, char* out,
                                std::size_t capacity) noexcept {
  if (capacity == 0) return 0;
  Out o{out, out + capacity - 1};  // room for the newline
  const can::Frame& f = r.frame;
  o.sdec(f.timestamp_ns);
  o.put(' ');
  o.put(iface);
  o.put(' ');
  o.dec(r.serial);
  o.put(' ');
  o.dec(r.node_id);
  o.put(' ');
  o.put(kind_name(r));
  o.put(' ');
  o.hex(f.id, f.is_extended() ? 8 : 3);
  o.put(' ');
  const std::uint8_t len = f.len > 8 ? std::uint8_t{8} : f.len;
  o.dec(len);
  o.put(' ');
  if (len == 0 || f.is_rtr()) {
    o.put('-');
  } else {
    for (std::uint8_t i = 0; i < len; ++i) o.hex(f.data[i], 2);
  }
  if (r.has_position) {
    o.put(" pos=");
    o.sdec(r.position);
  }
  if (r.has_speed) {
    o.put(" speed=");
    o.sdec(r.speed);
  }
  if (r.cam_state >= 0) {
    o.put(" cam=");
    o.sdec(r.cam_state);
  }
  if (r.work_area_state >= 0) {
    o.put(" area=");
    o.sdec(r.work_area_state);
  }
  if (r.kind == TruthRecord::Kind::emcy) {
    o.put(" emcy=");
    o.hex(r.emcy_code, 4);
  }
  *o.p++ = '\n';
  return static_cast<std::size_t>(o.p - out);
}

void TruthWriter::write(std::string_view iface, const TruthRecord& record, canopen::TimePoint now) noexcept {
  if (file_ == nullptr) return;
  if (kBufferBytes - used_ < kMaxLineBytes) flush();
  used_ += format(iface, record, buffer_.data() + used_, kMaxLineBytes);
  ++lines_;
  if (oldest_ == canopen::kNever) oldest_ = now;
}

canopen::TimePoint TruthWriter::process(canopen::TimePoint now) noexcept {
  if (oldest_ == canopen::kNever) return canopen::kNever;
  if (now - oldest_ >= kFlushPeriod) {
    flush();
    return canopen::kNever;
  }
  return oldest_ + kFlushPeriod;
}

void TruthWriter::flush() noexcept {
  oldest_ = canopen::kNever;
  if (file_ == nullptr || used_ == 0) {
    used_ = 0;
    return;
  }
  if (std::fwrite(buffer_.data(), 1, used_, file_) != used_) ++write_errors_;
  if (std::fflush(file_) != 0) ++write_errors_;
  used_ = 0;
}

}  // namespace cobridge::sim
