#include "app/command_line.hpp"

#include "app/control_command.hpp"

#include <CLI/CLI.hpp>
#include <net/if.h>

#include <map>
#include <set>
#include <sstream>

namespace cobridge::sim {

namespace {

constexpr const char* kDeviceHelp =
    "MODEL[:key=value,...] (repeatable; belongs to the preceding --iface). Keys:\n"
    "  serial=N        0x1018/4 and LSS serial, decimal or 0x hex (default: 1, 2, ... in\n"
    "                  command-line order, skipping serials given explicitly)\n"
    "  node=N          1..127 or 'unconfigured' (FFh, LSS only); default: the model's factory\n"
    "                  node-ID (127 Novotechnik, 32 ifm)\n"
    "  channels=1|2    rotary series only (1- or 2-channel variant)\n"
    "  bitrate=K       kbit/s: Novotechnik 50|125|250|500|800|1000, ifm 20..1000 (0x3001 table);\n"
    "                  default: ordering code / 125 (ifm)\n"
    "  lss=default|v1|v3|none   LSS feature set (default: rotary v1 = J's DSP-305 V1.1.2, no\n"
    "                  Fastscan/inquire; multiturn v3; ifm v3)\n"
    "  segmented=on|off  segmented SDO upload for long strings (default on)\n"
    "  fastscan=on|off   answer LSS Fastscan (v3 only, and only while unconfigured; default on)\n"
    "  c6=on|off         ifm only: the \"C6\" variant whose TPDO2 is active (F§7.3; default off)\n"
    "  lose_configure=N  the first N LSS configure node-ID requests get no answer (default 0)\n"
    "  late_lss=N,late_lss_ms=T  every Nth LSS answer leaves T ms late (1..255, 1..60000; default\n"
    "                  none): a slave slower than the master's LSS timeout\n"
    "  motion=SPEC     must be the last key (default constant:0); SPEC is one of\n"
    "                    constant:<turns/s>\n"
    "                    sine:<amplitude turns>:<period s>[:<offset turns>]\n"
    "                    steps:<t0 s>=<turns>;<t1 s>=<turns>;...   (piecewise constant)\n"
    "                    ramp:<turns/s>:<max turns>                (triangle 0 -> max -> 0)\n"
    "                    script:<path>   lines 'time_s turns', linear interpolation";

std::string models_line(ModelLookup lookup, std::span<const ModelInfo> models) {
  std::string out;
  for (const ModelInfo& m : models) {
    if (lookup(m.name) == nullptr) continue;
    if (!out.empty()) out += ", ";
    out += std::string(m.name) + " (" + std::string(family_name(m.family)) + ")";
  }
  return out;
}

bool valid_interface_name(const std::string& s) {
  if (s.empty() || s.size() >= IFNAMSIZ) return false;
  for (const char c : s)
    if (c == '/' || c == ' ' || c == ':' || c == '\t') return false;
  return true;
}

// What CLI11 fills in, before it is checked and resolved.
struct RawArguments {
  std::vector<std::string> ifaces;
  std::vector<std::string> devices;
  std::string state_dir, truth, control, devices_dir;
  int rt_priority = 0;
  const CLI::Option* iface_opt = nullptr;
  const CLI::Option* device_opt = nullptr;
};

void define_options(CLI::App& app, RawArguments& raw, ModelLookup lookup, std::span<const ModelInfo> models,
                    const std::filesystem::path& installed_devices_dir,
                    const std::filesystem::path& source_devices_dir) {
  raw.iface_opt = app.add_option("--iface", raw.ifaces, "CAN interface (repeatable); the --device options after it are on it")
                      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
                      ->type_size(1)
                      ->required();
  raw.device_opt = app.add_option("--device", raw.devices, kDeviceHelp)
                       ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
                       ->type_size(1)
                       ->required();
  app.add_option("--state-dir", raw.state_dir,
                 "directory of the devices' non-volatile memory (<family>-<serial>.nv); default: none "
                 "(nothing survives the process)");
  app.add_option("--truth", raw.truth, "write the truth file (one line per frame a device sent) to FILE");
  app.add_option("--control", raw.control, "also accept control commands on a Unix stream socket at PATH");
  app.add_option("--rt-priority", raw.rt_priority,
                 "run under SCHED_FIFO at priority N (1..99; needs CAP_SYS_NICE): the devices answer within\n"
                 "microseconds on a real bus, so beside the master on one CPU (UML) the simulator is not\n"
                 "made to wait behind it (default: the normal scheduler)")
      ->check(CLI::Range(1, 99));
  app.add_option("--devices-dir", raw.devices_dir,
                 "EDS directory (default: " + installed_devices_dir.string() + ", else " +
                     source_devices_dir.string() + ")");
  app.footer(std::string("Models: ") + models_line(lookup, models) + "\n\n" + std::string(control_help()) +
             "\nOn start-up every device is powered on (boot-up unless unconfigured) and 'ready' is\n"
             "printed on stdout. SIGTERM/SIGINT/quit end the program; the truth file is flushed.\n"
             "Exit codes: 0 normal end, 1 run-time failure (bus could not be opened), 2 bad arguments.");
}

// The devices in command-line order and the bus each belongs to.
struct PlacedDevices {
  std::vector<DeviceArgument> parsed;
  std::vector<std::size_t> bus_of;
};

// A bad command line (the caller adds the program's name).
Error bad(std::string message) { return Error(Errc::kInvalidArgument, std::move(message)); }

// Walks the options in command-line order so each --device lands on the
// --iface before it.
Error place_devices(const CLI::App& app, const RawArguments& raw, ModelLookup lookup,
                    std::vector<BusOptions>& buses, PlacedDevices& placed) {
  std::size_t next_iface = 0, next_device = 0;
  std::map<std::string, std::size_t> bus_index;
  for (const CLI::Option* opt : app.parse_order()) {
    if (opt == raw.iface_opt) {
      const std::string& name = raw.ifaces.at(next_iface++);
      if (!valid_interface_name(name))
        return bad("--iface '" + name + "': not an interface name (1.." + std::to_string(IFNAMSIZ - 1) +
                   " characters, no '/', ':' or blanks)");
      if (bus_index.count(name) != 0) return bad("--iface '" + name + "' given twice");
      bus_index[name] = buses.size();
      buses.push_back(BusOptions{name, {}});
    } else if (opt == raw.device_opt) {
      const std::string& text = raw.devices.at(next_device++);
      if (buses.empty())
        return bad("--device '" + text + "' comes before any --iface (a device belongs to the --iface before it)");
      auto r = parse_device_argument(text, lookup);
      if (!r.ok()) return r.error();
      placed.parsed.push_back(std::move(r).value());
      placed.bus_of.push_back(buses.size() - 1);
    }
  }
  for (const BusOptions& b : buses) {
    bool has_device = false;
    for (const std::size_t i : placed.bus_of) has_device = has_device || buses[i].iface == b.iface;
    if (!has_device) return bad("--iface '" + b.iface + "' has no --device after it");
  }
  return {};
}

// Explicit serials must be unique; the others count up from 1.
Error assign_serials(const PlacedDevices& placed, std::vector<BusOptions>& buses) {
  std::set<std::uint32_t> used;
  for (const DeviceArgument& d : placed.parsed) {
    if (!d.serial_given) continue;
    if (!used.insert(d.spec.serial).second)
      return bad("serial " + std::to_string(d.spec.serial) +
                 " is used by two devices (control commands and the state files need unique serials)");
  }
  std::uint32_t next_serial = 1;
  for (std::size_t i = 0; i < placed.parsed.size(); ++i) {
    DeviceSpec spec = placed.parsed[i].spec;
    if (!placed.parsed[i].serial_given) {
      while (used.count(next_serial) != 0) ++next_serial;
      spec.serial = next_serial;
      used.insert(next_serial);
    }
    buses[placed.bus_of[i]].devices.push_back(std::move(spec));
  }
  return {};
}

// The directories: --devices-dir, else the first default that exists.
Error resolve_directories(const RawArguments& raw, const std::filesystem::path& installed_devices_dir,
                          const std::filesystem::path& source_devices_dir, SimOptions& options) {
  if (!raw.devices_dir.empty()) {
    if (!std::filesystem::is_directory(raw.devices_dir))
      return bad("--devices-dir '" + raw.devices_dir + "': not a directory");
    options.devices_dir = raw.devices_dir;
  } else if (std::filesystem::is_directory(installed_devices_dir)) {
    options.devices_dir = installed_devices_dir;
  } else if (std::filesystem::is_directory(source_devices_dir)) {
    options.devices_dir = source_devices_dir;
  } else {
    return bad("no device descriptions: neither " + installed_devices_dir.string() + " nor " +
               source_devices_dir.string() + " exists (use --devices-dir)");
  }
  if (!raw.state_dir.empty() && std::filesystem::exists(raw.state_dir) &&
      !std::filesystem::is_directory(raw.state_dir))
    return bad("--state-dir '" + raw.state_dir + "': exists and is not a directory");
  return {};
}

// Checks and resolves what CLI11 parsed.
Error resolve(const CLI::App& app, const RawArguments& raw, ModelLookup lookup,
              const std::filesystem::path& installed_devices_dir, const std::filesystem::path& source_devices_dir,
              SimOptions& options) {
  PlacedDevices placed;
  if (Error e = place_devices(app, raw, lookup, options.buses, placed)) return e;
  if (Error e = assign_serials(placed, options.buses)) return e;
  options.state_dir = raw.state_dir;
  options.truth_file = raw.truth;
  options.control_path = raw.control;
  options.rt_priority = raw.rt_priority;
  return resolve_directories(raw, installed_devices_dir, source_devices_dir, options);
}

}  // namespace

int CommandLineResult::exit_code() const noexcept {
  if (error) return cobridge::exit_code(error.kind);
  return help.empty() ? -1 : 0;
}

std::string CommandLineResult::output() const { return error ? "cobridge-sim: " + error.to_string() : help; }

CommandLineResult parse_command_line(int argc, const char* const* argv, ModelLookup lookup,
                                     std::span<const ModelInfo> models,
                                     const std::filesystem::path& installed_devices_dir,
                                     const std::filesystem::path& source_devices_dir) {
  CommandLineResult result;
  CLI::App app{"cobridge-sim: simulated CANopen absolute encoders (Novotechnik rotary J, Novotechnik\n"
               "multiturn E, ifm RM8/RM9 F) on SocketCAN interfaces.",
               "cobridge-sim"};
  RawArguments raw;
  define_options(app, raw, lookup, models, installed_devices_dir, source_devices_dir);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    result.help = app.help();
    return result;
  } catch (const CLI::ParseError& e) {
    result.error = bad(std::string(e.what()) + "\nRun with --help for more information.");
    return result;
  }
  result.error = resolve(app, raw, lookup, installed_devices_dir, source_devices_dir, result.options);
  return result;
}

}  // namespace cobridge::sim
