// OutputPipeline: the daemon's hot path and outputs, assembled.
//
// One PluginHost with the enabled [outputs.<name>] plugins, one Dispatcher
// thread, and per bus a DeviceTable, a BusReceiver (the RX thread with its
// own kernel-filtered socket) and an OutputBridge (the BusObserver the bus
// manager reports to). A plugin that fails to load or start is reported and
// the others run; the buses are served whatever the outputs do.
// Threads: constructed, started and stopped by the daemon's main thread;
// observer(i) is handed to bus manager i and called on its control thread;
// set_command_target() is called by the main thread before the buses start
// and after they stop; plugin commands (ABI 2) arrive on plugin threads and
// are routed by device_index to the device's bus manager.
//
// The pipeline keeps its own copy of the configuration it started with: a
// reload (SIGHUP) changes device settings on the buses, while device
// indices, names and scales of the outputs stay as started (restart to
// change them).
#pragma once

#include "base/error.hpp"
#include "config/config.hpp"
#include "device/device_catalog.hpp"
#include "outputs/output_bridge.hpp"
#include "pipeline/bus_receiver.hpp"
#include "pipeline/device_table.hpp"
#include "pipeline/arrival_histograms.hpp"
#include "pipeline/last_values.hpp"
#include "pipeline/dispatcher.hpp"
#include "pipeline/plugin_host.hpp"

#include <atomic>
#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace cobridge::outputs {

// The plugins the configuration enables, as the plugin host loads them.
[[nodiscard]] std::vector<pipeline::PluginSpec> plugin_specs(const config::Config& config);

// Loads (dlopen + create, never start) every enabled output plugin from
// `plugin_dir`, so that a missing file, a wrong ABI or a setting the plugin
// refuses (an unknown key, a bad value) is found without touching a bus.
// Returns one Error per problem, where = "file:line:col: [outputs.<name>]".
[[nodiscard]] std::vector<Error> check_outputs(const config::Config& config, const std::filesystem::path& plugin_dir);

class OutputPipeline {
 public:
  OutputPipeline(const config::Config& config, const device::DeviceCatalog& catalog, std::filesystem::path plugin_dir);
  ~OutputPipeline();
  OutputPipeline(const OutputPipeline&) = delete;
  OutputPipeline& operator=(const OutputPipeline&) = delete;

  // Starting takes three steps, so that the slow one (a DDS participant
  // comes up in tenths of a second) overlaps the buses' start:
  //  1. load(): every plugin loaded and created (its settings checked),
  //     before any bus is touched;
  //  2. start_receivers(): the hot path's RX threads open their buses and
  //     fill the rings; the dispatcher holds samples and device
  //     announcements (Dispatcher::hold) until
  //  3. start_plugins(): the plugins start, then the dispatcher delivers
  //     everything held, in order. May run on a helper thread while the
  //     caller starts the bus managers; nothing else touches the pipeline
  //     meanwhile except the bus managers' observers and stats readers.
  // Each returns every problem (a plugin that cannot be loaded, created or
  // started, a receiver that cannot open its bus); any problem is fatal:
  // the daemon must not run without an output it was told to feed. After a
  // failed load() nothing is left loaded. Nothing here logs a problem: the
  // caller reports each one, once.
  [[nodiscard]] std::vector<Error> load();
  // Before start_receivers(): the bus's flight recorder (nullptr: none).
  void set_recorder(std::size_t bus_index, can::FrameRecorder* recorder);
  [[nodiscard]] std::vector<Error> start_receivers();
  [[nodiscard]] std::vector<Error> start_plugins();
  // The three in order (tests, tools).
  [[nodiscard]] std::vector<Error> start();
  void stop();

  // SIGHUP: the new configuration for the bridges (device settings such as
  // the event timer behind staleness, scaling) and for command routing.
  // Refused with the reason when it would move a device to another index
  // (what SCADA and cell controllers address it by): devices may only be
  // added at the end, or change their settings. Plugins keep their settings
  // (the caller refuses [outputs.*] changes). Main thread.
  [[nodiscard]] std::string reload(const config::Config& next);

  [[nodiscard]] bus::BusObserver* observer(std::size_t bus_index);
  // Where commands for the devices of bus `bus_index` go; nullptr = nowhere
  // (they are refused as offline).
  void set_command_target(std::size_t bus_index, bus::BusManager* target) noexcept;
  [[nodiscard]] std::size_t plugins_running() const noexcept { return host_.loaded_count(); }
  // Any thread: each output's own figures (Modbus clients, DDS writers, ...).
  [[nodiscard]] std::vector<pipeline::OutputStats> output_stats() const { return host_.stats(); }
  [[nodiscard]] pipeline::ReceiverStats receiver_stats(std::size_t bus_index) const;
  // Adds what the hot path knows to a bus manager's status: its counters and
  // each device's last values, heartbeat age and stale flag (ages against
  // `now`). Any thread; reads atomics only, never waits for the hot path.
  void add_live_status(std::size_t bus_index, bus::BusStatus& status, std::chrono::steady_clock::time_point now,
                       bus::WallTime wall_now) const;

 private:
  // The plugins first, then the last-value table the status reads.
  class HostSink final : public pipeline::SampleSink {
   public:
    HostSink(pipeline::PluginHost& host, pipeline::LastValues& last, pipeline::ArrivalHistograms& arrivals)
        : host_(host), last_(last), arrivals_(arrivals) {}
    void deliver(std::span<const pipeline::Sample> batch) noexcept override {
      host_.deliver(batch);
      last_.record(batch);
      arrivals_.record(batch);
    }

   private:
    pipeline::PluginHost& host_;
    pipeline::LastValues& last_;
    pipeline::ArrivalHistograms& arrivals_;
  };
  struct Bus {
    pipeline::DeviceTable table;
    std::unique_ptr<pipeline::BusReceiver> receiver;
    std::unique_ptr<OutputBridge> bridge;
  };

  // Plugin threads: cobridge_host_api.submit_command.
  [[nodiscard]] int submit(std::string_view instance, const cobridge_command& command) const;

  SharedConfig config_;
  DeviceIndexPool unknown_indices_;  // shared by every bus's bridge
  std::vector<std::atomic<bus::BusManager*>> command_targets_;
  pipeline::PluginHost host_;
  pipeline::LastValues last_values_;
  pipeline::ArrivalHistograms arrivals_;
  HostSink sink_;
  pipeline::Dispatcher dispatcher_;
  std::vector<std::unique_ptr<Bus>> buses_;
  bool started_ = false;
};

}  // namespace cobridge::outputs
