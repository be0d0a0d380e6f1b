// can::Frame: one classic CAN 2.0 frame as the layers above SocketCAN see it.
//
// A fixed-size, trivially copyable value so that it can travel through
// lock-free rings and be copied on the hot path without allocation. The
// SocketCAN channel fills `timestamp_ns` with the kernel receive time
// (CLOCK_REALTIME, SO_TIMESTAMPNS); frames built for sending leave it 0.
// Thread-safety: a plain value; no shared state.
#pragma once

#include <time.h>

#include <array>
#include <cstdint>
#include <type_traits>

namespace cobridge::can {

struct Frame {
  static constexpr uint8_t kFlagRtr = 0x01;       // remote transmission request
  static constexpr uint8_t kFlagExtended = 0x02;  // 29-bit identifier
  static constexpr uint8_t kFlagError = 0x04;     // error frame (CAN_ERR_FLAG)

  uint32_t id = 0;     // identifier without flag bits (11 or 29 bits)
  uint8_t len = 0;     // data length 0..8
  uint8_t flags = 0;   // kFlag* bits
  // Frames the kernel dropped at the receiving socket's full queue right
  // before this one (SO_RXQ_OVFL; saturates at 65535; 0 for frames built
  // here). Not part of the telegram: equality ignores it. It lets a
  // recording say where it has a gap instead of hiding one.
  uint16_t dropped_before = 0;
  std::array<uint8_t, 8> data{};
  int64_t timestamp_ns = 0;  // kernel receive time, ns since the Unix epoch

  [[nodiscard]] constexpr bool is_rtr() const noexcept { return (flags & kFlagRtr) != 0; }
  [[nodiscard]] constexpr bool is_extended() const noexcept { return (flags & kFlagExtended) != 0; }
  [[nodiscard]] constexpr bool is_error() const noexcept { return (flags & kFlagError) != 0; }

  // An 11-bit data frame with the given payload (len bytes of `bytes`).
  static constexpr Frame make(uint32_t cob_id, std::initializer_list<uint8_t> bytes) noexcept {
    Frame f;
    f.id = cob_id;
    uint8_t n = 0;
    for (uint8_t b : bytes) {
      if (n == 8) break;
      f.data[n++] = b;
    }
    f.len = n;
    return f;
  }
  // An 11-bit frame of exactly 8 data bytes (CiA 301 SDO and LSS frames).
  static constexpr Frame make8(uint32_t cob_id, const std::array<uint8_t, 8>& bytes) noexcept {
    Frame f;
    f.id = cob_id;
    f.len = 8;
    f.data = bytes;
    return f;
  }

  // Equality ignores the timestamp and dropped_before: two frames are the
  // same telegram.
  friend constexpr bool operator==(const Frame& a, const Frame& b) noexcept {
    if (a.id != b.id || a.len != b.len || a.flags != b.flags) return false;
    for (uint8_t i = 0; i < a.len && i < 8; ++i)
      if (a.data[i] != b.data[i]) return false;
    return true;
  }
};

// Now on the clock of Frame::timestamp_ns (CLOCK_REALTIME, ns since the
// epoch). A system call under UML: not for the hot path.
inline int64_t frame_clock_ns() noexcept {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

static_assert(std::is_trivially_copyable_v<Frame>);
static_assert(sizeof(Frame) == 24);

}  // namespace cobridge::can
