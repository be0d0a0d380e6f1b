#include "outputs/output_pipeline.hpp"

#include "sys/logging.hpp"

namespace cobridge::outputs {
namespace {

pipeline::PluginHost::Options host_options(const config::Config& config, std::filesystem::path dir,
                                           pipeline::PluginHost::CommandSink commands) {
  pipeline::PluginHost::Options o;
  o.commands = std::move(commands);
  o.plugin_dir = std::move(dir);
  o.gateway_id = config.gateway.id;
  if (config.redundancy) o.redundancy_node = config.redundancy->node_id;
  // A plugin's log lines go to the logger named after its instance ("dds", ...).
  o.log = [](pipeline::LogLevel level, std::string_view instance, std::string_view message) {
    sys::logger(instance)->log(static_cast<spdlog::level::level_enum>(level), "{}", message);
  };
  // Every load or start failure is returned to the caller, which reports it
  // with the configuration's file:line (the daemon's log, --check-config).
  o.log_failures = false;
  return o;
}

}  // namespace

std::vector<pipeline::PluginSpec> plugin_specs(const config::Config& config) {
  std::vector<pipeline::PluginSpec> specs;
  for (const auto& out : config.outputs) {
    if (!out.enabled) continue;
    pipeline::PluginSpec spec;
    spec.instance = out.name;
    spec.type = out.name;
    if (!out.plugin.empty()) spec.file = out.plugin;
    spec.config_toml = out.settings_toml;
    spec.where = out.where.to_string() + ": [outputs." + out.name + "]";
    specs.push_back(std::move(spec));
  }
  return specs;
}

std::vector<Error> check_outputs(const config::Config& config, const std::filesystem::path& plugin_dir) {
  pipeline::PluginHost host(host_options(config, plugin_dir, nullptr));
  return host.load_all(plugin_specs(config));
}

OutputPipeline::OutputPipeline(const config::Config& config, const device::DeviceCatalog& catalog,
                               std::filesystem::path plugin_dir)
    : config_(config),
      command_targets_(config.buses.size()),
      host_(host_options(config, std::move(plugin_dir), [this](std::string_view instance, const cobridge_command& c) { return submit(instance, c); })),
      last_values_(config.buses.size()),
      arrivals_(config.buses.size()),
      sink_(host_, last_values_, arrivals_),
      dispatcher_(sink_) {
  for (std::size_t i = 0; i < config.buses.size(); ++i) {
    auto bus = std::make_unique<Bus>();
    bus->receiver = std::make_unique<pipeline::BusReceiver>(
        pipeline::BusReceiverOptions{.bus_index = static_cast<std::uint8_t>(i), .interface = config.buses[i].interface},
        bus->table, dispatcher_);
    bus->bridge = std::make_unique<OutputBridge>(config_, i, catalog, bus->table, bus->receiver.get(), &host_,
                                                 &dispatcher_, &unknown_indices_);
    dispatcher_.add_source(bus->receiver->ring());
    buses_.push_back(std::move(bus));
  }
}

OutputPipeline::~OutputPipeline() { stop(); }

void OutputPipeline::set_recorder(std::size_t bus_index, can::FrameRecorder* recorder) {
  if (bus_index < buses_.size()) buses_[bus_index]->receiver->set_recorder(recorder);
}

std::vector<Error> OutputPipeline::load() {
  std::vector<Error> problems = host_.load_all(plugin_specs(*config_.get()));
  // Nothing else starts: no receiver opens a bus for outputs that are not there.
  if (!problems.empty()) host_.unload_all();
  return problems;
}

std::vector<Error> OutputPipeline::start_receivers() {
  const auto config = config_.get();
  std::vector<Error> problems;
  dispatcher_.hold();
  started_ = true;
  for (std::size_t i = 0; i < buses_.size(); ++i) {
    if (Error e = buses_[i]->receiver->start()) {
      e.where = "bus " + config->buses[i].name + ": hot path: " + e.where;
      problems.push_back(std::move(e));
    }
  }
  return problems;
}

std::vector<Error> OutputPipeline::start_plugins() {
  std::vector<Error> problems = host_.start_all();
  dispatcher_.start();  // delivers what was held, also when a plugin failed (the caller stops all)
  return problems;
}

std::vector<Error> OutputPipeline::start() {
  std::vector<Error> problems = load();
  if (!problems.empty()) return problems;
  problems = start_receivers();
  for (auto& e : start_plugins()) problems.push_back(std::move(e));
  return problems;
}

void OutputPipeline::stop() {
  if (!started_) return;
  started_ = false;
  for (auto& b : buses_) b->receiver->stop();
  dispatcher_.stop();  // delivers what the receivers pushed
  host_.stop_all();
}

void OutputPipeline::set_command_target(std::size_t bus_index, bus::BusManager* target) noexcept {
  if (bus_index < command_targets_.size()) command_targets_[bus_index].store(target, std::memory_order_release);
}

int OutputPipeline::submit(std::string_view instance, const cobridge_command& command) const {
  const auto kind = bus::command_kind(command.kind);
  if (!kind) return COBRIDGE_COMMAND_UNSUPPORTED;
  // device_index is the device's position in the configuration (OutputBridge::device_index).
  const auto config = config_.get();
  if (command.device_index >= config->devices.size()) return COBRIDGE_COMMAND_UNKNOWN_DEVICE;
  const config::Device& device = config->devices[command.device_index];
  if (device.bus_index >= command_targets_.size()) return COBRIDGE_COMMAND_UNKNOWN_DEVICE;
  bus::BusManager* target = command_targets_[device.bus_index].load(std::memory_order_acquire);
  if (target == nullptr) return COBRIDGE_COMMAND_OFFLINE;
  return static_cast<int>(
      target->submit(bus::DeviceCommand{device.name, *kind, command.value, command.tag, "plugin " + std::string(instance)}));
}

std::string OutputPipeline::reload(const config::Config& next) {
  const auto now = config_.get();
  if (next.buses.size() != now->buses.size()) return "the buses changed";
  const std::size_t common = std::min(now->devices.size(), next.devices.size());
  for (std::size_t i = 0; i < common; ++i) {
    if (now->devices[i].name != next.devices[i].name)
      return "device \"" + now->devices[i].name + "\" would move from index " + std::to_string(i) +
             " (the Modbus slot and DDS instance it is read by); add new devices after the existing ones";
  }
  if (next.devices.size() < now->devices.size())
    return "device \"" + now->devices.back().name + "\" was removed; indices must stay (restart to renumber)";
  config_.set(next);
  return {};
}

bus::BusObserver* OutputPipeline::observer(std::size_t bus_index) {
  return bus_index < buses_.size() ? buses_[bus_index]->bridge.get() : nullptr;
}

pipeline::ReceiverStats OutputPipeline::receiver_stats(std::size_t bus_index) const {
  return bus_index < buses_.size() ? buses_[bus_index]->receiver->stats() : pipeline::ReceiverStats{};
}

void OutputPipeline::add_live_status(std::size_t bus_index, bus::BusStatus& status, std::chrono::steady_clock::time_point now,
                                     bus::WallTime wall_now) const {
  if (bus_index >= buses_.size()) return;
  const Bus& bus = *buses_[bus_index];
  const pipeline::ReceiverStats hot = bus.receiver->stats();
  if (const auto cfg = config_.get(); bus_index < cfg->buses.size()) status.bitrate_kbit = cfg->buses[bus_index].bitrate_kbit;
  status.unknown_node_frames = hot.decoder.unknown_node;
  status.ring_drops = hot.ring_drops;
  status.hot_rx_frames = hot.decoder.frames;
  status.hot_kernel_drops = hot.kernel_drops;
  status.status_drops = hot.status_drops;
  status.bad_length_frames = hot.decoder.bad_length;
  const auto mono_ns = static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(now.time_since_epoch()).count());
  const auto wall_ns = static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(wall_now.time_since_epoch()).count());
  // The monotonic receive time when the sample had one (a step of the wall
  // clock must not make a value look fresh or old), else the wall clock.
  auto age = [&](std::uint64_t mono, std::uint64_t wall) {
    if (mono != 0) return mono <= mono_ns ? static_cast<double>(mono_ns - mono) / 1e9 : 0.0;
    return wall <= wall_ns ? static_cast<double>(wall_ns - wall) / 1e9 : 0.0;
  };
  for (bus::DeviceStatus& d : status.devices) {
    if (d.node_id == 0) continue;
    const pipeline::LastValue v = last_values_.read(bus_index, d.node_id);
    bus::LiveValues& out = d.values;
    if (v.heartbeat_wall_ns != 0) out.heartbeat_age_s = age(v.heartbeat_monotonic_ns, v.heartbeat_wall_ns);
    out.heartbeat_intervals = arrivals_.read(bus_index, d.node_id, pipeline::ArrivalKind::heartbeat);
    out.tpdo_intervals = arrivals_.read(bus_index, d.node_id, pipeline::ArrivalKind::tpdo);
    if (v.value_wall_ns == 0) continue;
    out.present = true;
    out.has_position = (v.valid & (COBRIDGE_VALID_POSITION | COBRIDGE_VALID_POSITION_ENG)) != 0;
    out.has_speed = (v.valid & COBRIDGE_VALID_SPEED) != 0;
    out.position = v.position;
    out.position_eng = v.position_eng;
    out.unit = bus.bridge->position_unit(d);
    out.speed = v.speed;
    out.age_s = age(v.value_monotonic_ns, v.value_wall_ns);
    out.at = bus::WallTime(std::chrono::duration_cast<bus::WallTime::duration>(std::chrono::nanoseconds(v.value_wall_ns)));
    out.stale = v.status_known != 0 && v.stale != 0;
  }
}

}  // namespace cobridge::outputs
