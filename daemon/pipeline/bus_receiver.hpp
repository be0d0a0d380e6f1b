// BusReceiver: the hot path of one CAN bus. Its RX thread owns a CAN_RAW
// socket filtered to what becomes samples (SYNC, EMCY, TPDO1, TPDO2,
// heartbeat), or, with a flight recorder, to every frame on the bus (SDO,
// LSS and NMT too, the daemon's own requests included); it receives in
// batches with kernel timestamps, copies each batch into the recorder,
// decodes each frame with the FrameDecoder (which drops what it does not
// publish) and pushes the samples into the bus's SPSC ring.
//
// Per frame nothing allocates, locks, throws or logs. A full ring drops the
// sample and counts it (stats().ring_drops); the kernel's own drops are
// counted by the channel (SO_RXQ_OVFL). Status changes from the control
// thread (online/offline) travel through a second small SPSC ring into the
// RX thread, which stamps them with the device's sequence number, so every
// sample of a device has exactly one producer.
// Threads: start()/stop()/post_status() from the bus's control thread;
// stats() from any thread; handle() only from the RX thread (or, without
// start(), from a benchmark or test).
#pragma once

#include "base/error.hpp"
#include "can/frame_recorder.hpp"
#include "can/socketcan_channel.hpp"
#include "pipeline/device_table.hpp"
#include "pipeline/dispatcher.hpp"
#include "pipeline/frame_decoder.hpp"
#include "pipeline/spsc_ring.hpp"

#include <atomic>
#include <cstdint>
#include <span>
#include <string>
#include <system_error>
#include <thread>

namespace cobridge::pipeline {

struct BusReceiverOptions {
  std::uint8_t bus_index = 0;
  std::string interface;            // empty: no socket (handle() driven by the caller)
  std::size_t ring_capacity = 1u << 16;
  int receive_buffer_bytes = 1 << 20;  // SO_RCVBUF: room for bursts at 1 Mbit/s
  std::chrono::milliseconds stale_check{10};
  // The flight recorder every received frame goes into (nullptr: none; the
  // socket then passes only what becomes samples). It must outlive the
  // receiver; only the RX thread writes it.
  can::FrameRecorder* recorder = nullptr;
};

// What the control thread tells the RX thread about a device: a change of
// its online/NMT state, or the outcome of a command a plugin submitted.
struct StatusEvent {
  enum class Kind : std::uint8_t { status, command };
  std::uint8_t node_id = 0;
  bool online = false;
  std::uint8_t nmt_state = 0;
  std::int64_t timestamp_ns = 0;
  Kind kind = Kind::status;
  // Kind::command (plugin.h ABI 2: cobridge_sample.command_*).
  std::uint8_t command_kind = 0;
  std::uint8_t command_status = 0;
  std::uint32_t command_tag = 0;
  std::uint32_t command_abort_code = 0;
};

struct ReceiverStats {
  DecoderStats decoder;
  std::uint64_t ring_drops = 0;      // samples lost because the ring was full
  std::uint64_t kernel_drops = 0;    // frames the kernel dropped (SO_RXQ_OVFL)
  std::uint64_t status_drops = 0;    // status events lost (control ring full)
};

class BusReceiver {
 public:
  BusReceiver(BusReceiverOptions options, const DeviceTable& table, Dispatcher& dispatcher);
  ~BusReceiver();
  BusReceiver(const BusReceiver&) = delete;
  BusReceiver& operator=(const BusReceiver&) = delete;

  [[nodiscard]] SpscRing<Sample>& ring() noexcept { return ring_; }

  // Opens the socket and starts the RX thread; the channel's Error when the
  // interface cannot be opened (where = the interface).
  [[nodiscard]] Error start();
  void stop();

  // Before start(): the flight recorder every frame goes into (nullptr: none).
  void set_recorder(can::FrameRecorder* recorder) noexcept { options_.recorder = recorder; }

  // Control thread: online/offline/NMT changes of a device, command outcomes.
  bool post_status(const StatusEvent& e) noexcept;

  // Decodes a batch and pushes the samples; returns samples pushed.
  std::size_t handle(std::span<const can::Frame> frames) noexcept;
  void refresh_plans() noexcept;

  [[nodiscard]] ReceiverStats stats() const noexcept;

 private:
  void run() noexcept;
  void push(const Sample& s) noexcept;
  void drain_status() noexcept;

  BusReceiverOptions options_;
  SpscRing<Sample> ring_;
  SpscRing<StatusEvent> status_ring_{256};
  FrameDecoder decoder_;
  Dispatcher& dispatcher_;
  can::SocketCanChannel channel_;
  std::thread thread_;
  int wake_fd_ = -1;
  std::atomic<bool> running_{false};
  std::atomic<std::uint64_t> ring_drops_{0}, status_drops_{0};
};

}  // namespace cobridge::pipeline
