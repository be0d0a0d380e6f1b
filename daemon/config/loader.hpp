// The configuration loader's shared state and the section readers' shape.
//
// config::load() (load.cpp) parses the TOML text and hands the tables to one
// Loader, whose readers are split by section, one file each: load_gateway,
// load_logging, load_bus, load_device (+ load_device_options for the
// per-device tables), load_outputs, load_web and load_cross_check. They share
// the diagnostics sink, the Config being filled and where the cross-checked
// fields were written, hence one class rather than free functions.
//
// Private to the config layer. Thread: the start-up / reload thread, one
// Loader per load; nothing shared between loads.
#pragma once

#include "config/config.hpp"
#include "config/known_models.hpp"
#include "config/load.hpp"
#include "config/table_reader.hpp"

#include <toml++/toml.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace cobridge::config::detail {

namespace fs = std::filesystem;

inline constexpr std::int64_t kU8 = std::numeric_limits<std::uint8_t>::max();
inline constexpr std::int64_t kU16 = std::numeric_limits<std::uint16_t>::max();
inline constexpr std::int64_t kU32 = std::numeric_limits<std::uint32_t>::max();
inline constexpr std::int64_t kI32Min = std::numeric_limits<std::int32_t>::min();
inline constexpr std::int64_t kI32Max = std::numeric_limits<std::int32_t>::max();

inline constexpr std::array<std::string_view, 7> kModules{"can", "canopen", "device", "gateway", "sys", "dds", "modbus"};

// Names used as DDS keys, in logs and in control-socket commands: keep them
// to characters that need no quoting anywhere.
bool is_identifier(std::string_view s);

// The kernel's rule (dev_valid_name): 1..15 bytes (IFNAMSIZ 16 with the
// NUL), not "." or "..", no '/', ':' or white space.
bool is_interface_name(std::string_view s);

// "n" or "low-high", decimal, 1 <= low <= high <= 127.
std::optional<std::pair<unsigned, unsigned>> parse_range(std::string_view text);

std::string host_name();

SourceLocation location(const DiagnosticSink& sink, const toml::node& n);

// "line:column", for messages that point at a second place.
std::string at(const SourceLocation& l);

inline const std::initializer_list<Choice<LogLevel>> kLevels{
    {"trace", LogLevel::trace}, {"debug", LogLevel::debug}, {"info", LogLevel::info},
    {"warn", LogLevel::warn},   {"error", LogLevel::error}, {"critical", LogLevel::critical},
    {"off", LogLevel::off}};

// Where the fields that are cross-checked between devices were written.
struct DeviceSpots {
  SourceLocation name, bus, node_id, serial;
  bool has_name = false, has_bus = false, has_serial = false;
};

struct BusSpots {
  SourceLocation name, interface;
  bool has_name = false, has_interface = false;
};

class Loader {
 public:
  Loader(std::string_view file, fs::path base_dir) : sink_(std::string(file)), base_dir_(std::move(base_dir)) {}

  // The whole file: every section, then the checks across sections.
  LoadResult run(std::string_view text);

 private:
  fs::path resolve(const std::string& p) const;
  std::optional<fs::path> absolute_path(TableReader& r, std::string_view key);
  // ---- [gateway] ---------------------------------------------------------
  void read_gateway(TableReader& top);
  // ---- [logging] ---------------------------------------------------------
  void read_logging(TableReader& top);
  // ---- [[bus]] -----------------------------------------------------------
  void read_node_pool(TableReader& r, Bus& bus);
  void read_tables(const toml::table& root, const char* key, void (Loader::*read)(const toml::table&));
  static std::string entry_context(std::string_view what, std::size_t ordinal, const toml::node* name_node);
  void read_name(TableReader& r, const toml::node* name_node, std::string& name, SourceLocation& spot,
                 bool& has_spot);
  void read_bus(const toml::table& t);
  void read_bus_interface(TableReader& r, Bus& bus, BusSpots& spots);
  void read_bus_sync(TableReader& r, Bus& bus);
  void read_bus_timeouts(TableReader& r, Bus& bus);
  void read_bus_recorder(TableReader& r, Bus& bus);
  // ---- [[device]] --------------------------------------------------------
  std::optional<MappingEntry> read_mapping_entry(TableReader& r, const toml::node& item);
  std::optional<TpdoSettings> read_tpdo(TableReader& device, std::string_view key);
  std::optional<Guarding> read_guarding(TableReader& device);
  std::optional<Scaling> read_scaling(TableReader& device);
  std::optional<WorkArea> read_work_area(TableReader& device);
  void read_cams(TableReader& device, Device& d, std::int64_t max_index);
  void read_device(const toml::table& t);
  void read_address(TableReader& r, Device& d, DeviceSpots& spots);
  const KnownModel* read_model(TableReader& r, Device& d);
  void read_communication(TableReader& r, Device& d);
  void read_functions(TableReader& r, Device& d, const KnownModel* model);
  void check_eds(TableReader& r, Device& d, const std::string& value);
  void check_identity(TableReader& r, const Device& d, const KnownModel& model);
  void read_preset(TableReader& r, Device& d, const KnownModel* model);
  // ---- [outputs.<name>] --------------------------------------------------
  void read_outputs(TableReader& top);
  // ---- [web] -------------------------------------------------------------
  void read_web(TableReader& top);
  // ---- [redundancy] -------------------------------------------------------
  void read_redundancy(TableReader& top);
  void check_redundancy_node();
  SourceLocation redundancy_node_spot_;
  // ---- checks across sections ---------------------------------------------
  void cross_check();
  std::map<std::string, std::size_t> check_buses();
  void check_devices(const std::map<std::string, std::size_t>& bus_by_name);
  void check_serials();
  static std::optional<std::uint32_t> vendor_of(const Device& d);

  void add(const SourceLocation& where, std::string message) { sink_.add(where.line, where.column, std::move(message)); }

  DiagnosticSink sink_;
  fs::path base_dir_;
  Config config_;
  std::vector<BusSpots> bus_spots_;
  std::vector<DeviceSpots> device_spots_;
};

}  // namespace cobridge::config::detail
