// The daemon's buses: one bus::BusManager per [[bus]] table, built with
// the output pipeline as observer and command target. Each BusManager owns
// its control thread; the set starts them in configuration order and stops
// them together.
//
// Thread: built, started, stopped and reloaded on the main thread; ready(),
// serving(), statuses() and request_commission() from any thread (the bus
// managers are safe to read from any thread).
#pragma once

#include "base/error.hpp"
#include "config/config.hpp"
#include "device/device_catalog.hpp"
#include "bus/bus_manager.hpp"
#include "app/flight_recorders.hpp"
#include "outputs/output_pipeline.hpp"
#include "bus/state_store.hpp"

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace cobridge::app {

class BusSet {
 public:
  // One BusManager per bus, connected to `outputs` (which must outlive them).
  // Each bus is put in `registry` while it runs (clients' commands find it there).
  void build(const config::Config& cfg, const device::DeviceCatalog& catalog, bus::StateStore& state,
             outputs::OutputPipeline& outputs, bus::BusRegistry& registry,
             const FlightRecorders* recorders = nullptr);

  // Starts every bus; on the first failure stops those started and returns
  // it as the bus gave it (where = "bus NAME: IFACE", its kind and code).
  [[nodiscard]] Error start();

  // In parallel: each stop() may take up to 1 s, and SIGTERM must be done in 1 s.
  void stop();

  void reload(const config::Config& cfg);

  [[nodiscard]] bool ready() const;    // every bus commissioned and configured
  [[nodiscard]] bool serving() const;  // every bus's control thread alive
  [[nodiscard]] std::size_t size() const noexcept { return buses_.size(); }
  [[nodiscard]] bus::BusManager& operator[](std::size_t i) { return *buses_[i]; }
  [[nodiscard]] std::vector<bus::BusStatus> statuses() const;

 private:
  std::vector<std::unique_ptr<bus::BusManager>> buses_;
};

}  // namespace cobridge::app
