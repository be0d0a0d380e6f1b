// SYNC (CiA 301 §7.2.5): the producer that paces synchronous PDOs, and the
// consumer-side decoding of a SYNC frame.
//
// The producer sends on its COB-ID (0x1005, default 0x80) once per
// communication cycle period (0x1006). With a synchronous counter overflow
// value (0x1019) of 2..240 each SYNC carries a counter 1..overflow in one
// data byte; with 0 it carries no data. The first SYNC goes out one period
// after start(). A late caller does not get a burst: missed periods are
// skipped and the period grid is kept.
//
// Decoding policy: CiA 301 allows DLC 0 (no counter) and DLC 1 (counter);
// anything longer is rejected as `wrong_length` (a device answers it with
// EMCY 0x8240 "unexpected SYNC data length"). A counter of 0 or above 240 is
// outside the CiA 301 range and rejected too. Whether the length matches the
// consumer's own 0x1019 is a separate check (`matches_overflow`), because the
// gateway listens to SYNCs without knowing every device's 0x1019.
//
// Thread: SyncProducer is driven by one thread (the gateway's bus thread);
// process() is noexcept and allocation-free. parse_sync() is safe anywhere.
#pragma once

#include <cstdint>
#include <string_view>
#include <system_error>

#include "can/frame.hpp"
#include "can/frame_sink.hpp"
#include "canopen/clock.hpp"
#include "canopen/cob_id.hpp"

namespace cobridge::canopen {

enum class SyncFrameError : uint8_t {
  none = 0,
  wrong_cob_id,
  wrong_length,      // DLC > 1 (CiA 301 EMCY 0x8240 case)
  remote_request,
  counter_out_of_range,  // counter 0 or > 240
};
[[nodiscard]] std::string_view to_string(SyncFrameError error) noexcept;

struct SyncMessage {
  bool has_counter = false;
  uint8_t counter = 0;  // 1..240 when has_counter
};
struct SyncParse {
  SyncFrameError error = SyncFrameError::none;
  SyncMessage message;
  [[nodiscard]] constexpr bool ok() const noexcept { return error == SyncFrameError::none; }
};
// `cob_id` is the 11-bit identifier from 0x1005 (bits 0-10).
[[nodiscard]] SyncParse parse_sync(const can::Frame& frame, uint32_t cob_id = cob::kSync) noexcept;
// CiA 301 §7.2.5.3: with overflow 0 a SYNC has no data, otherwise one byte
// with a counter no larger than the overflow value.
[[nodiscard]] bool matches_overflow(const SyncMessage& message, uint8_t overflow) noexcept;

// The 0x1005 value split into its fields (CiA 301 §7.5.2.5).
struct SyncCobId {
  uint32_t id = cob::kSync;
  bool producer = false;  // bit 30: this node generates SYNC
  bool extended = false;  // bit 29: 29-bit identifier
};
[[nodiscard]] constexpr SyncCobId decode_sync_cob_id(uint32_t value) noexcept {
  SyncCobId r;
  r.extended = (value & (1U << 29)) != 0;
  r.producer = (value & (1U << 30)) != 0;
  r.id = value & (r.extended ? 0x1FFFFFFFU : 0x7FFU);
  return r;
}

enum class SyncConfigErrc {
  zero_period = 1,
  invalid_overflow,  // 1 or 241..255: reserved in 0x1019
  invalid_cob_id,    // not an 11-bit identifier
};
[[nodiscard]] const std::error_category& sync_category() noexcept;
[[nodiscard]] std::error_code make_error_code(SyncConfigErrc e) noexcept;

class SyncProducer {
 public:
  struct Config {
    uint32_t cob_id = cob::kSync;
    Duration period{};
    uint8_t overflow = 0;  // 0 = no counter, 2..240 = counter wraps after this value
  };

  // Validates and takes the configuration; stops the producer.
  [[nodiscard]] std::error_code configure(const Config& config) noexcept;
  // Start at `now`: the counter restarts at 1 (CiA 301 resets it on start).
  void start(TimePoint now) noexcept;
  void stop() noexcept { running_ = false; }
  [[nodiscard]] bool running() const noexcept { return running_; }

  // Sends the SYNC if due; returns the next deadline (kNever when stopped).
  TimePoint process(TimePoint now, can::FrameSink& sink) noexcept;

  // The counter the next SYNC will carry.
  [[nodiscard]] uint8_t next_counter() const noexcept { return counter_; }
  [[nodiscard]] uint64_t sent() const noexcept { return sent_; }
  [[nodiscard]] uint64_t send_failures() const noexcept { return send_failures_; }

 private:
  Config config_{};
  bool configured_ = false;
  bool running_ = false;
  TimePoint next_{};
  uint8_t counter_ = 1;
  uint64_t sent_ = 0;
  uint64_t send_failures_ = 0;
};

}  // namespace cobridge::canopen

template <>
struct std::is_error_code_enum<cobridge::canopen::SyncConfigErrc> : std::true_type {};
