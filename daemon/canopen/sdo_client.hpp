// SdoClient: the client side of one SDO channel to one server (CiA 301 §7.2.4.3).
//
// A non-blocking state machine for expedited and segmented upload and download
// on the default SDO channel: requests go out on 0x600 + node-ID, responses come
// in on 0x580 + node-ID. One transfer at a time; the caller starts it, feeds
// every received frame to on_frame(), calls process(now) by the returned
// deadline, and collects the outcome with take_result(). Failures are
// std::error_codes in the "sdo_abort" category carrying the CiA 301 wire code,
// whether the server aborted or the client did (timeout, toggle, command
// specifier, size). Block transfer is not implemented (none of the three
// device families offers it: J§1.2.3, E§3.2).
//
// Why segmented support although the Novotechnik manuals say "segmented: no":
// the strings 0x1008..0x100A are longer than 4 bytes (J§1.3.1, E§4.1); the
// gateway must be able to read them from devices that do segment, and must
// tolerate an abort from those that do not.
//
// Thread: owned and driven by one thread (the bus thread that receives the
// server's frames). No allocation after construction, no exceptions, no clock.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <system_error>

#include "can/frame.hpp"
#include "can/frame_sink.hpp"
#include "canopen/clock.hpp"
#include "canopen/sdo_abort.hpp"

namespace cobridge::canopen {

struct SdoClientConfig {
  // Time the server may take to answer each request (CiA 301 leaves the value
  // to the application; 500 ms is what common masters use).
  Duration timeout = std::chrono::milliseconds{500};
  // How often an unanswered *initiate* request is re-sent before the transfer
  // is aborted with 0x05040000. Segment requests are never repeated: the
  // toggle protocol cannot tell a repeated segment from the next one.
  uint8_t retries = 0;
  // Largest upload or download, in bytes; allocated once at construction.
  std::size_t buffer_size = 1024;
  // Accept a download confirmation whose index matches but whose sub-index
  // does not. F§7.2.1 prints `60 10 10 00` as the answer to a write of
  // 0x1010/1 (most likely a misprint: CiA 301 echoes the sub-index); enable this only for a
  // device proven to answer that way.
  bool accept_download_sub_mismatch = false;
  // When a frame could not be queued mid-transfer, re-try sending it this
  // soon (process() reports it as the next deadline).
  Duration tx_retry = std::chrono::milliseconds{10};
};

class SdoClient {
 public:
  using Config = SdoClientConfig;

  enum class Direction : uint8_t { kUpload, kDownload };

  struct Result {
    uint16_t index = 0;
    uint8_t sub = 0;
    Direction direction = Direction::kUpload;
    std::error_code error;              // empty on success
    std::span<const uint8_t> data;      // upload payload; valid until the next start_*()

    [[nodiscard]] bool ok() const noexcept { return !error; }
    // Little-endian decoding of whatever arrived (CiA 301 §7.1.6: all numeric
    // types are little-endian). Shorter payloads are zero-/sign-extended from
    // their own width, so a 0x4B INTEGER16 answer of FF FF reads as -1.
    [[nodiscard]] uint32_t as_u32() const noexcept;
    [[nodiscard]] int32_t as_i32() const noexcept;
    [[nodiscard]] uint16_t as_u16() const noexcept { return static_cast<uint16_t>(as_u32()); }
    [[nodiscard]] uint8_t as_u8() const noexcept { return static_cast<uint8_t>(as_u32()); }
    // VISIBLE_STRING: the bytes up to the first NUL, if any.
    [[nodiscard]] std::string_view as_string() const noexcept;
  };

  SdoClient(can::FrameSink& sink, uint8_t node_id, Config cfg);
  SdoClient(const SdoClient&) = delete;
  SdoClient& operator=(const SdoClient&) = delete;

  // Changes the server addressed; refused with device_or_resource_busy during a
  // transfer and invalid_argument outside 1..127.
  std::error_code set_node_id(uint8_t node_id) noexcept;
  [[nodiscard]] uint8_t node_id() const noexcept { return node_id_; }
  [[nodiscard]] uint32_t request_cob_id() const noexcept;   // 0x600 + node-ID
  [[nodiscard]] uint32_t response_cob_id() const noexcept;  // 0x580 + node-ID

  // Start a transfer. Errors (nothing is sent, state unchanged apart from a
  // dropped untaken result): device_or_resource_busy while a transfer runs,
  // invalid_argument for a node-ID outside 1..127, value_too_large for a
  // download bigger than Config::buffer_size, no_buffer_space when the sink
  // refused the frame. The data are copied, the caller's span may die.
  // Downloads of 1..4 bytes go expedited with size (0x2F/0x2B/0x27/0x23),
  // others segmented with size indicated (0x21).
  std::error_code start_upload(uint16_t index, uint8_t sub, TimePoint now) noexcept;
  std::error_code start_download(uint16_t index, uint8_t sub, std::span<const uint8_t> data,
                                 TimePoint now) noexcept;

  // Feed a received frame. Returns true when it arrived on this client's
  // response COB-ID (whether or not it advanced the transfer), false for any
  // other frame. Frames of another length than 8 and responses naming another
  // object are ignored: the latter are late answers to a request that already
  // timed out, and acting on them would end the current transfer wrongly.
  bool on_frame(const can::Frame& frame, TimePoint now) noexcept;

  // Handles timeouts (abort 0x05040000 to the server) and retries; returns the
  // next deadline, kNever when idle.
  TimePoint process(TimePoint now) noexcept;

  // The caller gives up: sends the abort to the server and completes the
  // transfer with `code`. No effect when idle.
  void abort(SdoAbort code) noexcept;
  // The server lost the transfer (it rebooted, or the interface went away):
  // end it at once without a frame and without a result, so the client is
  // free for the next transfer. No effect when idle.
  void forget() noexcept;

  [[nodiscard]] bool busy() const noexcept { return state_ != State::kIdle; }
  [[nodiscard]] bool has_result() const noexcept { return result_.has_value(); }
  // The outcome of the last transfer, once; its data view stays valid until
  // the next start_*().
  std::optional<Result> take_result() noexcept;

 private:
  enum class State : uint8_t { kIdle, kDownloadInitiate, kDownloadSegment, kUploadInitiate, kUploadSegment };

  bool send(const can::Frame& frame) noexcept;
  bool send_request(const can::Frame& frame, TimePoint now) noexcept;
  // Records the state every transfer starts from once its first request is sent.
  void begin_transfer(const can::Frame& request, uint16_t index, uint8_t sub, State state, TimePoint now) noexcept;
  void send_abort(uint32_t code) noexcept;
  void fail(SdoAbort code) noexcept;  // abort to the server + complete with code
  void complete(std::error_code error, std::size_t upload_bytes) noexcept;
  [[nodiscard]] bool stale_initiate_response(const can::Frame& f, bool lenient_sub) const noexcept;
  void send_download_segment(TimePoint now) noexcept;
  void on_download_initiate(const can::Frame& f, TimePoint now) noexcept;
  void on_download_segment(const can::Frame& f, TimePoint now) noexcept;
  void on_upload_initiate(const can::Frame& f, TimePoint now) noexcept;
  void on_upload_segment(const can::Frame& f, TimePoint now) noexcept;

  can::FrameSink& sink_;
  uint8_t node_id_;
  Config cfg_;
  std::unique_ptr<uint8_t[]> buffer_;

  State state_ = State::kIdle;
  uint16_t index_ = 0;
  uint8_t sub_ = 0;
  bool toggle_ = false;
  bool size_indicated_ = false;   // upload: the server announced the size
  bool last_segment_sent_ = false;
  std::size_t size_ = 0;          // download: bytes to send; upload: announced size
  std::size_t offset_ = 0;        // bytes acknowledged (download) or received (upload)
  std::size_t segment_bytes_ = 0; // data bytes in the download segment awaiting confirmation
  uint8_t retries_left_ = 0;
  TimePoint deadline_ = kNever;
  can::Frame last_request_{};
  bool tx_pending_ = false;       // last_request_ still has to be queued
  TimePoint tx_retry_at_ = kNever;
  std::optional<Result> result_;
};

}  // namespace cobridge::canopen
