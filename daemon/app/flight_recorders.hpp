// The daemon's flight recorders: per bus with recorder_seconds > 0, the
// frame ring its RX thread fills (can::FrameRecorder) and the writer of the
// captures around its faults (bus::CaptureWriter), in
// <state_dir>/captures.
//
// Thread: build(), start() and stop() on the main thread; recorder() and
// captures() hand out pointers that stay valid until the object dies (the
// receivers and bus managers get them before they start, and are stopped
// before it is destroyed).
#pragma once

#include "base/error.hpp"
#include "bus/capture_writer.hpp"
#include "can/frame_recorder.hpp"
#include "config/config.hpp"

#include <memory>
#include <vector>

namespace cobridge::app {

class FlightRecorders {
 public:
  // One recorder per bus of `cfg` (none for a bus with recorder_seconds 0).
  void build(const config::Config& cfg);
  // Starts the capture writers; a bus whose captures directory cannot be
  // made records nothing to disk, and its Error is returned (the daemon
  // runs on: the recorder is a diagnostic aid, not a duty).
  [[nodiscard]] std::vector<Error> start();
  void stop();

  [[nodiscard]] can::FrameRecorder* recorder(std::size_t bus) const;
  [[nodiscard]] bus::CaptureWriter* captures(std::size_t bus) const;

 private:
  struct Bus {
    std::unique_ptr<can::FrameRecorder> recorder;
    std::unique_ptr<bus::CaptureWriter> writer;
  };
  std::vector<Bus> buses_;
};

}  // namespace cobridge::app
