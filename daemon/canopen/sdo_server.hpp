// SdoServer: the device side of the CiA 301 SDO protocol (one server channel).
//
// Used by the device simulator. It receives requests on 0x600+node, answers
// on 0x580+node, and reads/writes the device's ObjectDictionary. Supported:
// expedited download/upload, segmented download/upload (switchable, because
// the Novotechnik manuals say expedited only: J§1.2.4, E§3.2) and abort
// transfer. Block transfer is answered with abort 0x05040001 (no seed device
// supports it). At most one transfer is open at a time, as in CiA 301.
//
// Behaviour the standard leaves to the implementation, chosen here:
//   * a request whose DLC is not 8 is ignored without a reply (CiA 301 fixes
//     SDO frames at 8 bytes; answering a malformed frame could collide with a
//     correct server on a misconfigured bus);
//   * an initiate request while a transfer is open silently drops the old
//     transfer and starts the new one (the client evidently gave up on it);
//   * a segment request with no transfer open, or of the wrong direction,
//     is answered with abort 0x05040001 (for no transfer: index/sub 0);
//   * a received client abort (0x80) ends the open transfer without a reply.
//
// Thread: all calls come from the thread that drives the simulated device
// (the same one that owns the ObjectDictionary). on_frame() and process() are
// noexcept and do not allocate; the transfer buffer is allocated once in the
// constructor. The server never reads a clock: `now` is passed in and
// process() returns the next deadline (kNever when idle).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "can/frame.hpp"
#include "can/frame_sink.hpp"
#include "canopen/clock.hpp"
#include "canopen/object_dictionary.hpp"

namespace cobridge::canopen {

// Declared outside SdoServer so that `Config{}` can be a default argument.
struct SdoServerConfig {
  // Segmented transfer on/off. The Novotechnik manuals say "segmented: no"
  // (J§1.2.4, E§3.2), yet their 0x1008 names are longer than 4 bytes, so
  // the simulator segments by default: the master must handle both.
  bool segmented = true;
  // Abort sent when segmented is off and an upload needs it (object longer
  // than 4 bytes, or empty) or a segmented download is initiated. 0x08000000
  // "general error" because a simulator should only send codes the manual
  // lists (J§1.6.3, E§7.3), and 0x06010000 is not among them.
  uint32_t segmented_disabled_abort = 0x08000000;
  // Responses say how many bytes they carry: expedited upload 0x43/47/4B/4F
  // and segmented upload initiate 0x41 with the size. When false: 0x42 and
  // 0x40 (both allowed by CiA 301, listed as 0x42 in J§1.6.2 and E§7.2).
  bool respond_size_indicated = true;
  // A segmented transfer with no client frame for this long is aborted with
  // 0x05040000.
  Duration segment_timeout = std::chrono::milliseconds(1000);
  // Replaces the CiA 301 length codes 0x06070010/12/13 when non-zero. The
  // manuals list no length code (J§1.6.3, E§7.3); 0x08000000 "general
  // error" is the listed code nearest to it.
  uint32_t length_abort_override = 0;
  // Transfer buffer size; 0 means the dictionary's largest value (at least 4).
  // Values larger than the buffer are refused with 0x05040005 (out of memory).
  size_t buffer_size = 0;
};

class SdoServer {
 public:
  using Config = SdoServerConfig;

  SdoServer(can::FrameSink& sink, ObjectDictionary& od, uint8_t node_id, Config config = Config{});

  // Handles a received frame. Returns true when the frame was addressed to
  // this server (request COB-ID, 11-bit data frame), whether or not it was
  // answered; false for all other frames and while disabled.
  bool on_frame(const can::Frame& frame, TimePoint now) noexcept;
  // Aborts a segmented transfer that timed out; returns the next deadline.
  TimePoint process(TimePoint now) noexcept;

  // Changes the COB-IDs (0x600/0x580 + node); drops an open transfer.
  void set_node_id(uint8_t node_id) noexcept;
  [[nodiscard]] uint8_t node_id() const noexcept { return node_id_; }
  // A disabled server neither receives nor sends (a simulated pulled cable).
  // Disabling drops an open transfer: the client will time out on its own.
  void set_enabled(bool enabled) noexcept;
  [[nodiscard]] bool enabled() const noexcept { return enabled_; }

  [[nodiscard]] bool transfer_open() const noexcept { return state_ != State::kIdle; }
  // Responses the sink refused (the client will time out and retry).
  [[nodiscard]] uint64_t tx_failures() const noexcept { return tx_failures_; }

 private:
  enum class State : uint8_t { kIdle, kUploading, kDownloading };

  void initiate_download(const can::Frame& f, TimePoint now) noexcept;
  void download_segment(const can::Frame& f, TimePoint now) noexcept;
  void initiate_upload(const can::Frame& f, TimePoint now) noexcept;
  void upload_segment(const can::Frame& f, TimePoint now) noexcept;
  void send_abort(uint16_t index, uint8_t sub, uint32_t code) noexcept;
  void send(const std::array<uint8_t, 8>& bytes) noexcept;
  void reset() noexcept;
  [[nodiscard]] uint32_t map_code(uint32_t code) const noexcept;

  can::FrameSink& sink_;
  ObjectDictionary& od_;
  Config config_;
  uint8_t node_id_ = 0;
  bool enabled_ = true;

  State state_ = State::kIdle;
  uint16_t index_ = 0;
  uint8_t sub_ = 0;
  bool toggle_ = false;          // expected toggle bit of the next segment
  bool size_indicated_ = false;  // download: client gave the total size
  size_t total_ = 0;             // upload: bytes to send; download: announced size
  size_t done_ = 0;              // bytes sent / received so far
  size_t limit_ = 0;             // download: the object's capacity
  TimePoint deadline_ = kNever;
  std::vector<uint8_t> buffer_;
  uint64_t tx_failures_ = 0;
};

}  // namespace cobridge::canopen
