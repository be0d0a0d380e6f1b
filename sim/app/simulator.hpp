// Simulator: cobridge-sim as a whole. It loads the device descriptions,
// opens one SimulatedBus per interface with its devices, writes the truth
// file and runs the loop: poll() on the CAN sockets, the control channel and
// the signal fd, with the timeout taken from the earliest device deadline
// (ppoll with a nanosecond timeout; how late each timed wake-up was is
// measured and shown by the `stats` control command).
// Thread: main thread only; everything runs in its loop.
#pragma once

#include "app/command_line.hpp"
#include "app/control_channel.hpp"
#include "app/control_command.hpp"
#include "app/simulated_bus.hpp"
#include "app/truth_writer.hpp"
#include "device/device_catalog.hpp"

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace cobridge::sys {
class Signals;
}

namespace cobridge::sim {

struct LoopStats {
  std::uint64_t turns = 0;
  std::uint64_t timed_wakes = 0;         // poll returned because the deadline came
  std::uint64_t late_over_1ms = 0;       // ... more than 1 ms after the deadline
  std::int64_t max_late_ns = 0;
  std::uint64_t late_sum_ns = 0;
  std::uint64_t busy_over_1ms = 0;  // turns that took more than 1 ms from wake-up to the next wait
  std::int64_t max_busy_ns = 0;
};

class Simulator {
 public:
  explicit Simulator(SimOptions options);
  ~Simulator();
  Simulator(const Simulator&) = delete;
  Simulator& operator=(const Simulator&) = delete;

  // Loads descriptions, opens buses, truth file and control socket, creates
  // and powers on the devices. Prints nothing. A failure's kind gives the
  // exit code: kFailed (1) when a bus cannot be opened, kInvalidArgument (2)
  // for what the command line named.
  [[nodiscard]] Error start();
  // Runs until quit or a stop signal. Returns the exit code.
  int run(sys::Signals& signals);

  // One control line -> one reply line (without newline).
  [[nodiscard]] std::string execute(std::string_view line);

 private:
  struct Located {
    SimulatedBus* bus = nullptr;
    std::size_t index = 0;
  };
  [[nodiscard]] std::optional<Located> find_device(std::uint32_t serial);
  [[nodiscard]] SimulatedBus* find_bus(std::string_view iface);
  [[nodiscard]] std::string list() const;
  [[nodiscard]] std::string stats() const;
  void note_busy(canopen::TimePoint turn_start) noexcept;
  // Opens every --iface bus and creates its devices (not yet powered).
  [[nodiscard]] Error open_buses();
  // The control commands on a bus (flood, babble, bus-error) and on a device.
  [[nodiscard]] std::string execute_on_bus(const ControlCommand& c, canopen::TimePoint now);
  [[nodiscard]] std::string execute_on_device(const ControlCommand& c, canopen::TimePoint now);

  SimOptions options_;
  device::DeviceCatalog catalog_;  // before the buses: the devices point into it
  std::vector<std::unique_ptr<SimulatedBus>> buses_;
  TruthWriter truth_;
  ControlChannel control_;
  LoopStats loop_;
  bool quit_ = false;
  canopen::TimePoint now_{};  // time of the current loop turn (or control command)
};

}  // namespace cobridge::sim
