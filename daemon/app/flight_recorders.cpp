#include "app/flight_recorders.hpp"

namespace cobridge::app {

void FlightRecorders::build(const config::Config& cfg) {
  buses_.clear();
  buses_.resize(cfg.buses.size());
  for (std::size_t i = 0; i < cfg.buses.size(); ++i) {
    const config::Bus& b = cfg.buses[i];
    if (b.recorder_seconds == 0) continue;
    Bus& bus = buses_[i];
    bus.recorder = std::make_unique<can::FrameRecorder>(
        can::FrameRecorder::capacity_for(b.bitrate_kbit, b.recorder_seconds));
    bus::CaptureOptions o;
    o.dir = cfg.gateway.state_dir / "captures";
    o.bus = b.name;
    o.interface = b.interface;
    o.before = std::chrono::seconds(b.recorder_seconds);
    o.after = std::chrono::milliseconds(b.capture_after_ms);
    o.cap_bytes = std::uint64_t{b.capture_cap_mib} << 20;
    o.budget_per_hour = b.capture_budget_per_hour;
    bus.writer = std::make_unique<bus::CaptureWriter>(std::move(o), *bus.recorder);
  }
}

std::vector<Error> FlightRecorders::start() {
  std::vector<Error> problems;
  for (Bus& b : buses_) {
    if (!b.writer) continue;
    if (Error e = b.writer->start()) {
      problems.push_back(std::move(e));
      b.writer.reset();  // nothing would write its requests
    }
  }
  return problems;
}

void FlightRecorders::stop() {
  for (Bus& b : buses_)
    if (b.writer) b.writer->stop();
}

can::FrameRecorder* FlightRecorders::recorder(std::size_t bus) const {
  return bus < buses_.size() ? buses_[bus].recorder.get() : nullptr;
}

bus::CaptureWriter* FlightRecorders::captures(std::size_t bus) const {
  return bus < buses_.size() ? buses_[bus].writer.get() : nullptr;
}

}  // namespace cobridge::app
