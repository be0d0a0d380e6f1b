#include "outputs/output_bridge.hpp"

#include "device/family_profile.hpp"
#include "sys/logging.hpp"

#include <array>
#include <ctime>
#include <memory>

namespace cobridge::outputs {
namespace {

std::int64_t realtime_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000LL + ts.tv_nsec;
}

std::uint8_t nmt_byte(canopen::NmtState s) noexcept { return static_cast<std::uint8_t>(s); }

// plugin.h ABI 6: what the device's drift records say of its configuration.
std::uint8_t config_state_of(const bus::DeviceStatus& device) {
  if (device.drift.empty()) return COBRIDGE_CONFIG_AS_CONFIGURED;
  return bus::contested_count(device) > 0 ? COBRIDGE_CONFIG_CONTESTED : COBRIDGE_CONFIG_DIFFERS;
}

}  // namespace

OutputBridge::OutputBridge(const SharedConfig& config, std::size_t bus_index, const device::DeviceCatalog& catalog,
                           pipeline::DeviceTable& table, pipeline::BusReceiver* receiver, pipeline::PluginHost* host,
                           pipeline::Dispatcher* dispatcher, DeviceIndexPool* unknown_indices)
    : config_(config),
      bus_index_(bus_index),
      catalog_(catalog),
      table_(table),
      receiver_(receiver),
      host_(host),
      dispatcher_(dispatcher),
      unknown_indices_(unknown_indices) {}

std::optional<std::uint16_t> OutputBridge::device_index(const bus::DeviceStatus& device) {
  const auto cfg = config_.get();
  for (std::size_t i = 0; i < cfg->devices.size() && i < DeviceIndexPool::kFirst; ++i)
    if (cfg->devices[i].name == device.name) return static_cast<std::uint16_t>(i);
  if (unknown_indices_ == nullptr) return std::nullopt;
  return unknown_indices_->acquire(std::to_string(bus_index_) + "/" + device.name);
}

void OutputBridge::on_device_removed(const bus::DeviceStatus& device) {
  if (unknown_indices_ != nullptr) unknown_indices_->release(std::to_string(bus_index_) + "/" + device.name);
  {
    std::lock_guard lock(mutex_);
    node_of_.erase(device.name);
    online_.erase(device.node_id);
  }
  if (device.node_id != 0) table_.remove(device.node_id);
}

pipeline::DecodePlan OutputBridge::make_plan(const bus::DeviceStatus& device, const std::vector<std::uint32_t>& tpdo1,
                                             const std::vector<std::uint32_t>& tpdo2, Error* error) const {
  pipeline::DecodePlan plan;
  plan.node_id = device.node_id;
  const auto candidates = catalog_.candidates(device.identity.vendor, device.identity.product);
  const device::DeviceDescription* desc = candidates.empty() ? nullptr : candidates.front();
  auto mapped = [&](const std::vector<std::uint32_t>& entries) {
    std::vector<pipeline::MappedObject> out;
    for (std::uint32_t e : entries) {
      const auto index = static_cast<std::uint16_t>(e >> 16);
      const auto sub = static_cast<std::uint8_t>(e >> 8);
      bool is_signed = false;
      if (desc) {
        const device::ObjectDesc* od = desc->find(index, sub);
        // The multiturn default mapping names 0x6020/1, an alias of 0x6004 (E§4.1 0x1A00/1, E§8.2).
        if (!od && index == 0x6020) od = desc->find(0x6004, 0);
        if (od) is_signed = device::is_signed_integer(od->data_type);
      }
      out.push_back({e, is_signed});
    }
    return out;
  };
  Error err = pipeline::build_pdo_decode(mapped(tpdo1), plan.tpdo[0]);
  if (!err) err = pipeline::build_pdo_decode(mapped(tpdo2), plan.tpdo[1]);
  if (err) {
    err.where = "device '" + device.name + "'";
    if (error != nullptr) *error = std::move(err);
    return pipeline::DecodePlan{};
  }
  // Engineering units: degrees of the shaft when the measuring units per
  // revolution are known (configured, or the EDS default of 0x6001 / 0x6501);
  // ifm prints "see label" (F§7.5), so there the value stays in counts.
  const auto cfg_now = config_.get();
  const double units_per_rev = this->units_per_rev(*cfg_now, device, desc);
  if (units_per_rev > 0) plan.eng_scale = 360.0 / units_per_rev;
  if (desc) {
    if (const auto profile = device::family_profile_for(*desc)) plan.position_mask = profile->position_value_mask;
  }
  if (const config::Device* cfg = cfg_now->find_device(device.name)) {
    const config::TpdoSettings* t[2] = {cfg->tpdo1 ? &*cfg->tpdo1 : nullptr, cfg->tpdo2 ? &*cfg->tpdo2 : nullptr};
    for (std::size_t i = 0; i < 2; ++i) {
      if (!t[i]) continue;
      if (t[i]->transmission && *t[i]->transmission >= 1 && *t[i]->transmission <= 240) plan.synchronous[i] = true;
    }
    // Stale after three missed event-timer periods (plus scheduling slack).
    if (cfg->tpdo1 && cfg->tpdo1->event_timer_ms && *cfg->tpdo1->event_timer_ms > 0)
      plan.max_age_ms = 3u * *cfg->tpdo1->event_timer_ms + 20u;
  }
  plan.active = true;
  return plan;
}

double OutputBridge::units_per_rev(const config::Config& config, const bus::DeviceStatus& device,
                                   const device::DeviceDescription* desc) const {
  const config::Device* cfg = config.find_device(device.name);
  if (cfg && cfg->scaling && cfg->scaling->units_per_rev) return static_cast<double>(*cfg->scaling->units_per_rev);
  if (desc) {
    for (std::uint16_t index : {std::uint16_t{0x6001}, std::uint16_t{0x6501}}) {
      if (const auto* od = desc->find(index, 0))
        if (auto v = od->default_for_node(device.node_id); v && *v > 0) return static_cast<double>(*v);
    }
  }
  return 0;
}

void OutputBridge::on_device_configured(const bus::DeviceStatus& device, const std::vector<std::uint32_t>& tpdo1_mapping,
                                        const std::vector<std::uint32_t>& tpdo2_mapping) {
  Error error;
  pipeline::DecodePlan plan = make_plan(device, tpdo1_mapping, tpdo2_mapping, &error);
  if (!plan.active) {
    sys::logger("gateway")->error("{}", error.to_string());
    return;
  }
  const auto index = device_index(device);
  if (!index) {
    sys::logger("gateway")->warn("device {}: no device index left for devices the configuration does not name; "
                                 "not published", device.name);
    return;
  }
  plan.device_index = *index;
  plan.indexed = true;
  forget_old_node(device);
  table_.publish(plan);
  announce(device, COBRIDGE_DEVICE_ADDED);
}

void OutputBridge::on_device_status(const bus::DeviceStatus& device) {
  if (device.node_id == 0) return;
  // Known at this node from now on: its heartbeats, EMCY and status carry
  // its own index, never a default one.
  forget_old_node(device);
  const auto index = device_index(device);
  if (!index) return;  // not published: see on_device_configured
  table_.publish_index(device.node_id, *index);
  bool online_changed = false;
  bool config_changed = false;
  {
    std::lock_guard lock(mutex_);
    auto it = online_.find(device.node_id);
    online_changed = it == online_.end() || it->second != device.online;
    online_[device.node_id] = device.online;
    std::uint8_t& config = config_states_[device.node_id];  // new: as configured
    config_changed = config != config_state_of(device);
    config = config_state_of(device);
  }
  if (!online_changed && !config_changed) return;  // no change for the outputs
  if (online_changed && receiver_)
    (void)receiver_->post_status(pipeline::StatusEvent{.node_id = device.node_id,
                                                       .online = device.online,
                                                       .nmt_state = nmt_byte(device.nmt),
                                                       .timestamp_ns = realtime_ns()});
  announce(device, COBRIDGE_DEVICE_CHANGED);
}

void OutputBridge::forget_old_node(const bus::DeviceStatus& device) {
  std::uint8_t old = 0;
  {
    std::lock_guard lock(mutex_);
    auto [it, added] = node_of_.try_emplace(device.name, device.node_id);
    if (!added && it->second != device.node_id) {
      old = it->second;
      it->second = device.node_id;
      online_.erase(old);
      config_states_.erase(old);
    }
  }
  // The device moved (commissioning, swap): frames at its old node-ID are no
  // longer its own.
  if (old != 0) table_.remove(old);
}

void OutputBridge::on_command_done(const bus::DeviceStatus& device, const bus::DeviceCommand& command,
                                   const bus::CommandOutcome& outcome) {
  // Through the RX thread like every sample of the device (one producer,
  // one sequence); a device without a node-ID has no samples at all.
  if (receiver_ == nullptr || device.node_id == 0) return;
  pipeline::StatusEvent e;
  e.kind = pipeline::StatusEvent::Kind::command;
  e.node_id = device.node_id;
  e.timestamp_ns = realtime_ns();
  e.command_kind = static_cast<std::uint8_t>(command.kind);
  e.command_status = static_cast<std::uint8_t>(outcome.status);
  e.command_tag = command.tag;
  e.command_abort_code = outcome.abort_code;
  (void)receiver_->post_status(e);
}

const char* OutputBridge::position_unit(const bus::DeviceStatus& device) const {
  const auto cfg = config_.get();
  const auto candidates = catalog_.candidates(device.identity.vendor, device.identity.product);
  return units_per_rev(*cfg, device, candidates.empty() ? nullptr : candidates.front()) > 0 ? "deg" : "counts";
}

void OutputBridge::announce(const bus::DeviceStatus& device, std::uint8_t change) {
  if (!host_ || !dispatcher_) return;
  const auto cfg = config_.get();
  const std::string bus = bus_index_ < cfg->buses.size() ? cfg->buses[bus_index_].name : std::string();
  cobridge_device_info info{};
  info.struct_size = sizeof info;
  const auto index = device_index(device);
  if (!index) return;
  info.device_index = *index;
  info.bus_index = static_cast<std::uint8_t>(bus_index_);
  info.node_id = device.node_id;
  info.change = change;
  info.vendor_id = device.identity.vendor;
  info.product_code = device.identity.product;
  info.revision = device.identity.revision;
  info.serial = device.identity.serial;
  info.config_state = config_state_of(device);
  const char* unit = position_unit(device);
  // plugin.h: on_device runs on the dispatcher thread, like on_samples. The
  // task owns copies of the strings the info points to.
  auto strings = std::make_shared<std::array<std::string, 5>>(
      std::array<std::string, 5>{device.name, bus, device.model, device.family, unit});
  pipeline::PluginHost* host = host_;
  dispatcher_->post([host, info, strings]() mutable {
    info.name = (*strings)[0].c_str();
    info.bus_name = (*strings)[1].c_str();
    info.model = (*strings)[2].c_str();
    info.family = (*strings)[3].c_str();
    info.position_unit = (*strings)[4].c_str();
    host->announce(info);
  });
}

void OutputBridge::on_role_changed(const bus::BusRole& role) {
  if (!host_ || !dispatcher_) return;
  const auto cfg = config_.get();
  cobridge_role_info info{};
  info.struct_size = sizeof info;
  info.bus_index = static_cast<std::uint8_t>(bus_index_);
  info.role = role.kind == bus::BusRole::Kind::master    ? COBRIDGE_ROLE_MASTER
              : role.kind == bus::BusRole::Kind::standby ? COBRIDGE_ROLE_STANDBY
                                                    : COBRIDGE_ROLE_UNDECIDED;
  info.own_node = role.own_node;
  info.master_node = role.master_node;
  info.peer_node = role.peer_node;
  info.since_ns = role.since_ns;
  // In order with the samples (plugin.h): a plugin switches its DDS
  // ownership strength between two batches, never inside one.
  auto strings = std::make_shared<std::array<std::string, 2>>(std::array<std::string, 2>{
      bus_index_ < cfg->buses.size() ? cfg->buses[bus_index_].name : std::string(), role.cause});
  pipeline::PluginHost* host = host_;
  dispatcher_->post([host, info, strings]() mutable {
    info.bus_name = (*strings)[0].c_str();
    info.cause = (*strings)[1].c_str();
    host->announce_role(info);
  });
}

cobridge_bus_info to_bus_info(const bus::BusHealth& health, std::size_t bus_index) {
  const can::ControllerHealth& c = health.controller;
  cobridge_bus_info info{};
  info.struct_size = sizeof info;
  info.bus_index = static_cast<std::uint8_t>(bus_index);
  info.open = health.open ? 1 : 0;
  // ControllerState and HealthSource are in the ABI's order (static_asserts below).
  info.state = static_cast<std::uint8_t>(c.state);
  info.source = static_cast<std::uint8_t>(c.source);
  info.counters_known = c.counters_known ? 1 : 0;
  info.driver_reports_state = c.driver == can::DriverReport::state      ? 1
                              : c.driver == can::DriverReport::no_state ? 0
                                                                        : 2;
  info.tx_errors = c.counters_known ? c.tx_errors : 0;
  info.rx_errors = c.counters_known ? c.rx_errors : 0;
  info.restarts = c.restarts;
  info.error_frames = health.error_frames;
  info.since_ns = static_cast<std::uint64_t>(c.since_ns);
  return info;
}

static_assert(static_cast<int>(can::ControllerState::unknown) == COBRIDGE_CONTROLLER_UNKNOWN);
static_assert(static_cast<int>(can::ControllerState::error_active) == COBRIDGE_CONTROLLER_ERROR_ACTIVE);
static_assert(static_cast<int>(can::ControllerState::error_warning) == COBRIDGE_CONTROLLER_ERROR_WARNING);
static_assert(static_cast<int>(can::ControllerState::error_passive) == COBRIDGE_CONTROLLER_ERROR_PASSIVE);
static_assert(static_cast<int>(can::ControllerState::bus_off) == COBRIDGE_CONTROLLER_BUS_OFF);
static_assert(static_cast<int>(can::HealthSource::none) == COBRIDGE_SOURCE_NONE);
static_assert(static_cast<int>(can::HealthSource::error_frames) == COBRIDGE_SOURCE_ERROR_FRAMES);
static_assert(static_cast<int>(can::HealthSource::netlink) == COBRIDGE_SOURCE_NETLINK);

void OutputBridge::on_bus_health(const bus::BusHealth& health) {
  if (!host_ || !dispatcher_) return;
  const auto cfg = config_.get();
  cobridge_bus_info info = to_bus_info(health, bus_index_);
  // In order with the samples (plugin.h), like on_role.
  auto name = std::make_shared<std::string>(bus_index_ < cfg->buses.size() ? cfg->buses[bus_index_].name
                                                                            : std::string());
  pipeline::PluginHost* host = host_;
  dispatcher_->post([host, info, name]() mutable {
    info.bus_name = name->c_str();
    host->announce_bus(info);
  });
}

}  // namespace cobridge::outputs
