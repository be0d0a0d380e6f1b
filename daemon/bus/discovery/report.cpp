// Discovery's events and step timings: see report.hpp.
#include "bus/discovery/report.hpp"

#include <chrono>

namespace cobridge::bus::discovery {

void Report::problem(std::string text, std::uint8_t node, const canopen::LssAddress& id) {
  if (!reported_problems_.insert(text).second) return;
  DiscoveryEvent e;
  e.kind = DiscoveryEventKind::problem;
  e.node_id = node;
  e.identity = id;
  e.text = std::move(text);
  events_.push_back(std::move(e));
}

void Report::timing(std::string step, std::string device, canopen::Duration d) {
  StepTiming t;
  t.step = std::move(step);
  t.device = std::move(device);
  t.milliseconds = std::chrono::duration<double, std::milli>(d).count();
  timings_.push_back(std::move(t));
}

void Report::timing(std::string step, std::string device, const canopen::LssMaster::Result& r) {
  timing(std::move(step), std::move(device), r.elapsed);
  timings_.back().exchanges = r.steps;
  timings_.back().timeouts = r.silent_steps;
  timings_.back().restarts = r.restarts;
}

}  // namespace cobridge::bus::discovery
