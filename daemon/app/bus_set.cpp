#include "app/bus_set.hpp"

#include <algorithm>
#include <thread>

namespace cobridge::app {

void BusSet::build(const config::Config& cfg, const device::DeviceCatalog& catalog, bus::StateStore& state,
                   outputs::OutputPipeline& outputs, bus::BusRegistry& registry,
                   const FlightRecorders* recorders) {
  for (std::size_t i = 0; i < cfg.buses.size(); ++i) {
    bus::BusManagerOptions options;
    options.observer = outputs.observer(i);
    options.registry = &registry;
    options.captures = recorders ? recorders->captures(i) : nullptr;
    buses_.push_back(std::make_unique<bus::BusManager>(cfg, i, catalog, state, options));
    outputs.set_command_target(i, buses_.back().get());
  }
}

Error BusSet::start() {
  for (std::size_t i = 0; i < buses_.size(); ++i) {
    if (Error e = buses_[i]->start()) {
      stop();
      e.message = "cannot start: " + e.message;
      return e;
    }
  }
  return {};
}

void BusSet::stop() {
  std::vector<std::thread> stoppers;
  for (auto& b : buses_) stoppers.emplace_back([&b] { b->stop(); });
  for (auto& t : stoppers) t.join();
}

void BusSet::reload(const config::Config& cfg) {
  for (auto& b : buses_) b->reload(cfg);
}

bool BusSet::ready() const {
  return std::all_of(buses_.begin(), buses_.end(), [](const auto& b) { return b->ready(); });
}

bool BusSet::serving() const {
  return std::all_of(buses_.begin(), buses_.end(), [](const auto& b) { return b->serving(); });
}

std::vector<bus::BusStatus> BusSet::statuses() const {
  std::vector<bus::BusStatus> out;
  for (const auto& b : buses_) out.push_back(b->status());
  return out;
}

}  // namespace cobridge::app
