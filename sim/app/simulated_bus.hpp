// SimulatedBus: one CAN interface of cobridge-sim with the devices on it.
//
// All devices of a bus share one SocketCAN channel. A CAN_RAW socket does not
// receive the frames it sent itself, so what one simulated device sends is
// also handed to the other simulated devices of the bus here, in process,
// through a fixed ring (never re-entrantly: a device's on_frame never runs
// inside another device's send). The bus also carries the bus-level faults:
// while it floods, the devices lose arbitration and their frames are refused.
// Slaves that answer one LSS request with the same frame (CiA 305: every
// slave a Fastscan step or an identify request matches answers it) send it at
// the same instant, and identical frames put on the wire together are one
// frame there: the bus sends the first and counts the others as merged.
// Thread: the simulator's loop thread. receive/process/the device sinks are
// the per-frame path: no allocation, no logging.
#pragma once

#include "app/bus_fault.hpp"
#include "can/socketcan_channel.hpp"
#include "canopen/clock.hpp"
#include "device/sim_device.hpp"

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace cobridge::sim {

struct BusStats {
  std::uint64_t device_frames = 0;      // frames devices put on the bus
  std::uint64_t device_refused = 0;     // device frames refused (flood, channel full or down)
  std::uint64_t local_deliveries = 0;   // frames handed to sibling devices in process
  std::uint64_t local_overflow = 0;     // sibling deliveries lost because the ring was full
  std::uint64_t received = 0;           // frames received from the interface
  std::uint64_t injected = 0;           // flood / babble / error frames sent
  std::uint64_t lss_merged = 0;         // LSS answers identical to one already sent for the same request
};

class SimulatedBus {
 public:
  static constexpr std::size_t kLocalRing = 1024;  // frames in flight between siblings
  static constexpr std::size_t kBurst = 32;        // flood/babble frames per loop turn

  explicit SimulatedBus(std::string iface);
  ~SimulatedBus();
  SimulatedBus(const SimulatedBus&) = delete;
  SimulatedBus& operator=(const SimulatedBus&) = delete;

  [[nodiscard]] Error open();
  [[nodiscard]] const std::string& iface() const noexcept { return iface_; }
  [[nodiscard]] can::SocketCanChannel& channel() noexcept { return channel_; }

  // The sink a device on this bus sends through (index = order of add_device).
  [[nodiscard]] can::FrameSink& sink_for(std::size_t device_index);
  void add_device(std::unique_ptr<SimDevice> device);
  [[nodiscard]] std::size_t size() const noexcept { return devices_.size(); }
  [[nodiscard]] SimDevice& device(std::size_t i) noexcept { return *devices_[i]; }
  void set_silent(std::size_t i, bool silent);
  [[nodiscard]] bool silent(std::size_t i) const noexcept { return silent_[i] != 0; }

  // Reads what arrived and hands it to every device; bounded per call.
  void receive(canopen::TimePoint now) noexcept;
  // Runs every device's process(), the flood/babble generator and the
  // channel's reopen logic; returns the earliest deadline.
  [[nodiscard]] canopen::TimePoint process(canopen::TimePoint now) noexcept;

  // Bus faults. Error frames go on the wire and to the devices.
  [[nodiscard]] bool send_error_frame(BusErrorKind kind, canopen::TimePoint now) noexcept;
  void start_flood(canopen::TimePoint now, canopen::Duration d) noexcept { traffic_.start_flood(now, d); }
  void start_babble(std::uint32_t id, canopen::TimePoint now, canopen::Duration d) noexcept {
    traffic_.start_babble(id, now, d);
  }

  [[nodiscard]] const BusStats& stats() const noexcept { return stats_; }
  // The frame of the last device send was merged with an identical LSS
  // answer already on the wire: it left with that frame, at its time.
  [[nodiscard]] bool last_send_merged() const noexcept { return last_send_merged_; }
  // Delivers the sibling frames queued so far (also called by receive/process).
  void deliver_local(canopen::TimePoint now) noexcept;

 private:
  class DeviceSink;
  struct Local {
    can::Frame frame;
    std::uint32_t source;  // device index, or kNoDevice for injected frames
  };
  static constexpr std::uint32_t kNoDevice = UINT32_MAX;

  bool device_send(std::size_t index, const can::Frame& frame) noexcept;
  [[nodiscard]] bool merges_with_sent_answer(const can::Frame& frame) noexcept;
  void queue_local(const can::Frame& frame, std::uint32_t source) noexcept;

  std::string iface_;
  can::SocketCanChannel channel_;
  std::vector<std::unique_ptr<SimDevice>> devices_;
  std::vector<std::unique_ptr<DeviceSink>> sinks_;
  std::vector<std::uint8_t> silent_;
  std::array<Local, kLocalRing> ring_{};
  std::size_t head_ = 0;  // next to deliver
  std::size_t tail_ = 0;  // next free
  bool delivering_ = false;
  // While a received frame is handed to the devices (one instant on the
  // wire): the LSS answer sent for it, if any.
  bool in_instant_ = false;
  bool lss_answered_ = false;
  can::Frame lss_answer_{};
  bool last_send_merged_ = false;
  canopen::TimePoint now_{};
  TrafficGenerator traffic_;
  std::array<can::Frame, can::SocketCanChannel::kBatch> rx_{};
  BusStats stats_;
};

}  // namespace cobridge::sim
