// TruthWriter: the truth file of cobridge-sim, one text line per frame a
// simulated device sent, with what the device meant by it (position, speed,
// CAM and work-area state, EMCY code). End-to-end tests compare what reached
// the gateway's outputs against it. Format (docs/devices.md, "Truth file"):
//
//   <timestamp_ns> <iface> <serial> <node> <kind> <cob-id hex> <len> <data hex|-> [pos=<n>]
//   [speed=<n>] [cam=<n>] [area=<n>] [emcy=<code hex>]
//
// Lines are formatted by hand into a fixed buffer and written with fwrite;
// the buffer goes to the file when it fills, when process() finds it older
// than the flush period (100 ms), and on flush()/destruction.
// Thread: the simulator's loop thread; write() is on the per-frame path and
// neither allocates nor throws.
#pragma once

#include "base/error.hpp"
#include "canopen/clock.hpp"
#include "device/sim_device.hpp"

#include <array>
#include <chrono>
#include <cstdio>
#include <string_view>
#include <system_error>

namespace cobridge::sim {

class TruthWriter {
 public:
  static constexpr std::size_t kBufferBytes = 64 * 1024;
  static constexpr std::size_t kMaxLineBytes = 256;
  static constexpr auto kFlushPeriod = std::chrono::milliseconds(100);

  TruthWriter() = default;
  ~TruthWriter();
  TruthWriter(const TruthWriter&) = delete;
  TruthWriter& operator=(const TruthWriter&) = delete;

  // Creates (truncates) the file. Off the hot path. A failure has the path
  // as its where and the errno as its code.
  [[nodiscard]] Error open(const char* path);
  // Takes an already open stream (tests use fmemopen/tmpfile); not closed by us.
  void attach(std::FILE* stream) noexcept;
  [[nodiscard]] bool is_open() const noexcept { return file_ != nullptr; }

  // Appends one line. `iface` must stay short (an interface name).
  void write(std::string_view iface, const TruthRecord& record, canopen::TimePoint now) noexcept;
  // Flushes when data has waited kFlushPeriod; returns when to call again.
  canopen::TimePoint process(canopen::TimePoint now) noexcept;
  void flush() noexcept;

  [[nodiscard]] std::uint64_t lines() const noexcept { return lines_; }
  [[nodiscard]] std::uint64_t write_errors() const noexcept { return write_errors_; }

  // Formats one line (with '\n') into `out`; returns its length. Exposed for tests.
  static std::size_t format(std::string_view iface, const TruthRecord& record, char* out,
                            std::size_t capacity) noexcept;
  [[nodiscard]] static std::string_view kind_name(const TruthRecord& record) noexcept;

 private:
  std::FILE* file_ = nullptr;
  bool owned_ = false;
  std::array<char, kBufferBytes> buffer_{};
  std::size_t used_ = 0;
  canopen::TimePoint oldest_ = canopen::kNever;  // when the oldest unflushed line was added
  std::uint64_t lines_ = 0;
  std::uint64_t write_errors_ = 0;
};

}  // namespace cobridge::sim
