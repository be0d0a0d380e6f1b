// OutputBridge: what the bus managers learn, turned into what the hot path
// and the output plugins need.
//
// On every device the control thread has configured it builds the device's
// DecodePlan (mapping as verified, signedness of each mapped object from the
// EDS, position mask and engineering scale from the family and settings)
// and publishes it to the bus's DeviceTable; online/offline changes go to
// the bus's RX thread as StatusEvents (so every sample of a device keeps one
// producer and one sequence); device identities go to the plugins
// (cobridge_device_info) through the plugin host; command outcomes go to the
// RX thread too, which turns them into COMMAND samples; the bus's health
// and the pair's role go to the plugins (ABI 5 on_bus, ABI 4 on_role).
// Threads: the BusObserver callbacks run on each bus's control thread; the
// bridge hands plugin announcements to the dispatcher thread (plugin.h).
#pragma once

#include "config/config.hpp"
#include "device/device_catalog.hpp"
#include "bus/bus_manager.hpp"
#include "outputs/device_index_pool.hpp"
#include "outputs/shared_config.hpp"
#include "pipeline/bus_receiver.hpp"
#include "pipeline/device_table.hpp"
#include "pipeline/plugin_host.hpp"

#include <map>
#include <mutex>
#include <string>

namespace cobridge::outputs {

// A bus's health in the plugin ABI's terms (plugin.h ABI 5 cobridge_bus_info;
// bus_name left null: the caller points it at storage that outlives the call).
// Pure; exposed for tests.
[[nodiscard]] cobridge_bus_info to_bus_info(const bus::BusHealth& health, std::size_t bus_index);

class OutputBridge final : public bus::BusObserver {
 public:
  // `host`/`dispatcher` may be nullptr (no plugins); device announcements run
  // on the dispatcher thread. Everything passed must outlive the bridge.
  OutputBridge(const SharedConfig& config, std::size_t bus_index, const device::DeviceCatalog& catalog,
               pipeline::DeviceTable& table, pipeline::BusReceiver* receiver, pipeline::PluginHost* host,
               pipeline::Dispatcher* dispatcher, DeviceIndexPool* unknown_indices = nullptr);

  void on_device_configured(const bus::DeviceStatus& device, const std::vector<std::uint32_t>& tpdo1_mapping,
                            const std::vector<std::uint32_t>& tpdo2_mapping) override;
  void on_device_status(const bus::DeviceStatus& device) override;
  void on_command_done(const bus::DeviceStatus& device, const bus::DeviceCommand& command,
                       const bus::CommandOutcome& outcome) override;
  void on_device_removed(const bus::DeviceStatus& device) override;
  void on_role_changed(const bus::BusRole& role) override;
  void on_bus_health(const bus::BusHealth& health) override;

  // The plan that would be published (exposed for tests); an inactive plan
  // when the mapping cannot be decoded, `error` (if given) then says why
  // (where = the device).
  [[nodiscard]] pipeline::DecodePlan make_plan(const bus::DeviceStatus& device, const std::vector<std::uint32_t>& tpdo1,
                                               const std::vector<std::uint32_t>& tpdo2, Error* error) const;
  // The gateway-wide device index: the position in the configuration, or
  // one of DeviceIndexPool's for a device the configuration does not name;
  // none when that pool is used up (the device is then not published).
  [[nodiscard]] std::optional<std::uint16_t> device_index(const bus::DeviceStatus& device);
  // The unit of the device's position_eng as the plugins are told it: "deg"
  // when the measuring units per revolution are known, else "counts". Any thread.
  [[nodiscard]] const char* position_unit(const bus::DeviceStatus& device) const;

 private:
  // Measuring units per revolution, or 0 when unknown (then position_eng is in counts).
  double units_per_rev(const config::Config& cfg, const bus::DeviceStatus& device,
                       const device::DeviceDescription* desc) const;
  void announce(const bus::DeviceStatus& device, std::uint8_t change);
  void forget_old_node(const bus::DeviceStatus& device);

  const SharedConfig& config_;  // a reload replaces it; every callback takes a snapshot
  std::size_t bus_index_;
  const device::DeviceCatalog& catalog_;
  pipeline::DeviceTable& table_;
  pipeline::BusReceiver* receiver_;
  pipeline::PluginHost* host_;
  pipeline::Dispatcher* dispatcher_;
  std::mutex mutex_;
  DeviceIndexPool* unknown_indices_;
  std::map<std::uint8_t, bool> online_;  // last online state posted per node
  std::map<std::uint8_t, std::uint8_t> config_states_;  // last cobridge_config_state announced per node
  std::map<std::string, std::uint8_t> node_of_;  // where each device was last seen
};

}  // namespace cobridge::outputs
