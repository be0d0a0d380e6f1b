#include "config/load.hpp"
#include "config/toml_limits.hpp"

#include "config/known_models.hpp"
#include "config/remote_access_section.hpp"
#include "config/table_reader.hpp"
#include "sys/install_paths.hpp"

#include <toml++/toml.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <system_error>

namespace cobridge::config {
namespace {

namespace fs = std::filesystem;

constexpr std::int64_t kU8 = std::numeric_limits<std::uint8_t>::max();
constexpr std::int64_t kU16 = std::numeric_limits<std::uint16_t>::max();
constexpr std::int64_t kU32 = std::numeric_limits<std::uint32_t>::max();
constexpr std::int64_t kI32Min = std::numeric_limits<std::int32_t>::min();
constexpr std::int64_t kI32Max = std::numeric_limits<std::int32_t>::max();

constexpr std::array<std::string_view, 7> kModules{"can", "canopen", "device", "gateway", "sys", "dds", "modbus"};

// Names used as DDS keys, in logs and in control-socket commands: keep them
// to characters that need no quoting anywhere.
bool is_identifier(std::string_view s) {
  if (s.empty() || s.size() > 64) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' ||
           c == '.';
  });
}

// The kernel's rule (dev_valid_name): 1..15 bytes (IFNAMSIZ 16 with the
// NUL), not "." or "..", no '/', ':' or white space.
bool is_interface_name(std::string_view s) {
  if (s.empty() || s.size() > 15 || s == "." || s == "..") return false;
  return std::none_of(s.begin(), s.end(), [](char c) {
    const auto u = static_cast<unsigned char>(c);
    return c == '/' || c == ':' || u <= 0x20 || u == 0x7F;
  });
}

// "n" or "low-high", decimal, 1 <= low <= high <= 127.
std::optional<std::pair<unsigned, unsigned>> parse_range(std::string_view text) {
  auto number = [](std::string_view digits) -> std::optional<unsigned> {
    unsigned v = 0;
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), v);
    if (digits.empty() || ec != std::errc{} || end != digits.data() + digits.size()) return std::nullopt;
    return v;
  };
  const auto dash = text.find('-');
  const auto low = number(text.substr(0, dash));
  const auto high = dash == std::string_view::npos ? low : number(text.substr(dash + 1));
  if (!low || !high || *low < 1 || *high > 127 || *low > *high) return std::nullopt;
  return std::make_pair(*low, *high);
}

std::string host_name() {
  std::array<char, 256> buf{};
  if (::gethostname(buf.data(), buf.size() - 1) != 0 || buf[0] == '\0') return "cobridge";
  return buf.data();
}

SourceLocation location(const DiagnosticSink& sink, const toml::node& n) {
  return SourceLocation{sink.file(), n.source().begin.line, n.source().begin.column};
}

std::string at(const SourceLocation& l) { return std::to_string(l.line) + ":" + std::to_string(l.column); }

const std::initializer_list<Choice<LogLevel>> kLevels{
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

  LoadResult run(std::string_view text) {
    // Before the parser, which recurses per nesting level (issue 10, item 13).
    if (const auto v = check_toml_limits(text)) {
      sink_.add(v->line, v->column, v->message);
      return LoadResult(sink_.take_sorted());
    }
    toml::table root;
    try {
      root = toml::parse(text, std::string_view{sink_.file()});
    } catch (const toml::parse_error& e) {
      sink_.add(e.source().begin, "TOML syntax error: " + std::string(e.description()));
      return LoadResult(sink_.take_sorted());
    }
    TableReader top(root, "the top level", "", "", sink_);
    top.check_keys({"gateway", "logging", "bus", "device", "outputs", "web", "control", "ascii_gateway"});
    read_gateway(top);
    read_logging(top);
    read_tables(root, "bus", &Loader::read_bus);
    read_tables(root, "device", &Loader::read_device);
    read_outputs(top);
    read_web(top);
    read_remote_access(top, sink_, config_.remote);
    cross_check();
    if (!sink_.empty()) return LoadResult(sink_.take_sorted());
    config_.source = sink_.file();
    return LoadResult(std::move(config_));
  }

 private:
  fs::path resolve(const std::string& p) const {
    fs::path path(p);
    return path.is_absolute() || base_dir_.empty() ? path : base_dir_ / path;
  }

  // An absolute path, or nothing (reported).
  std::optional<fs::path> absolute_path(TableReader& r, std::string_view key) {
    auto s = r.string(key);
    if (!s) return std::nullopt;
    if (s->empty() || (*s)[0] != '/') {
      r.error(*r.find(key), r.path(key) + " must be an absolute path, got " + in_quotes(*s));
      return std::nullopt;
    }
    return fs::path(*s);
  }

  // ---- [gateway] ---------------------------------------------------------

  void read_gateway(TableReader& top) {
    auto& g = config_.gateway;
    g.id = host_name();
    g.state_dir = "/var/lib/cobridge";
    // The installed descriptions (<prefix>/share/cobridge/devices beside the
    // running executable) come first, when there are any: a build tree has none.
    g.device_dirs.clear();
    if (fs::path installed = sys::installed_or(sys::InstallDir::devices, {}); !installed.empty())
      g.device_dirs.push_back(std::move(installed));
    g.control_socket = "/run/cobridge/control.sock";
    const toml::table* t = top.subtable("gateway");
    if (t == nullptr) return;
    TableReader r(*t, "[gateway]", "", "gateway.", sink_);
    r.check_keys({"id", "state_dir", "device_dirs", "control_socket"});
    if (auto id = r.string("id")) {
      if (is_identifier(*id)) {
        g.id = *id;
      } else {
        r.error(*r.find("id"), "gateway.id " + in_quotes(*id) + " is not allowed (allowed: 1 to 64 of A-Z a-z 0-9 _ - .)");
      }
    }
    if (auto p = absolute_path(r, "state_dir")) g.state_dir = *p;
    if (auto p = absolute_path(r, "control_socket")) {
      // sockaddr_un::sun_path holds 108 bytes with its NUL (unix(7)).
      if (p->string().size() >= 108) {
        r.error(*r.find("control_socket"), "control_socket is " + std::to_string(p->string().size()) +
                                               " bytes long; a Unix socket path may have at most 107");
      } else {
        g.control_socket = *p;
      }
    }
    if (const toml::array* dirs = r.array("device_dirs")) {
      for (const toml::node& e : *dirs) {
        const auto* s = e.as_string();
        if (s == nullptr) {
          r.wrong_type(e, "gateway.device_dirs entry", "a string");
          continue;
        }
        const fs::path dir = resolve(s->get());
        std::error_code ec;
        if (!fs::is_directory(dir, ec)) {
          r.error(e, "gateway.device_dirs entry " + in_quotes(dir.string()) + " is not a directory");
          continue;
        }
        g.device_dirs.push_back(dir);
      }
    }
  }

  // ---- [logging] ---------------------------------------------------------

  void read_logging(TableReader& top) {
    auto& l = config_.logging;
    const toml::table* t = top.subtable("logging");
    if (t == nullptr) return;
    TableReader r(*t, "[logging]", "", "logging.", sink_);
    r.check_keys({"level", "target", "modules"});
    if (auto v = r.choice<LogLevel>("level", kLevels)) l.level = *v;
    if (auto v = r.choice<LogTarget>(
            "target", {{"auto", LogTarget::automatic}, {"console", LogTarget::console}, {"journal", LogTarget::journal}})) {
      l.target = *v;
    }
    const toml::table* m = r.subtable("modules");
    if (m == nullptr) return;
    TableReader mr(*m, "[logging.modules]", "", "logging.modules.", sink_);
    mr.check_keys({kModules[0], kModules[1], kModules[2], kModules[3], kModules[4], kModules[5], kModules[6]});
    // Walk in file order so later use (and messages) follow the file.
    std::vector<std::pair<toml::source_position, std::string>> present;
    for (auto&& [key, value] : *m) {
      if (std::find(kModules.begin(), kModules.end(), key.str()) != kModules.end()) {
        present.emplace_back(value.source().begin, std::string(key.str()));
      }
    }
    std::sort(present.begin(), present.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [pos, module] : present) {
      if (auto v = mr.choice<LogLevel>(module, kLevels)) l.modules.emplace_back(module, *v);
    }
  }

  // ---- [[bus]] -----------------------------------------------------------

  // Accepts "10-60", "10", 10, or an array of those.
  void read_node_pool(TableReader& r, Bus& bus) {
    const toml::node* n = r.find("node_pool");
    if (n == nullptr) {
      for (int id = 1; id <= 127; ++id) bus.node_pool.push_back(static_cast<std::uint8_t>(id));
      return;
    }
    std::array<bool, 128> in_pool{};
    bool ok = true;
    auto add_item = [&](const toml::node& item) {
      if (const auto* i = item.as_integer()) {
        const std::int64_t v = i->get();
        if (v < 1 || v > 127) {
          r.error(item, "node_pool entry " + std::to_string(v) + " is out of range (allowed: 1..127)");
          ok = false;
          return;
        }
        in_pool[static_cast<std::size_t>(v)] = true;
        return;
      }
      const auto* s = item.as_string();
      if (s == nullptr) {
        r.wrong_type(item, "node_pool entry", "an integer or a string like \"10-60\"");
        ok = false;
        return;
      }
      const std::string& text = s->get();
      const auto range = parse_range(text);
      if (!range) {
        r.error(item, "node_pool " + in_quotes(text) +
                          " is not a valid node-ID range (allowed: \"low-high\" with 1 <= low <= high <= 127, or a node-ID)");
        ok = false;
        return;
      }
      const auto [low, high] = *range;
      for (unsigned id = low; id <= high; ++id) in_pool[id] = true;
    };
    if (const auto* a = n->as_array()) {
      for (const toml::node& item : *a) add_item(item);
    } else {
      add_item(*n);
    }
    if (!ok) return;
    for (std::size_t id = 1; id <= 127; ++id) {
      if (in_pool[id]) bus.node_pool.push_back(static_cast<std::uint8_t>(id));
    }
    if (bus.node_pool.empty() && bus.commissioning == Commissioning::automatic) {
      r.error(*n, "node_pool is empty but commissioning is \"automatic\" (give node-IDs to assign, or set "
                  "commissioning to \"manual\" or \"off\")");
    }
  }

  // `key` must be an array of tables ([[key]]); `read` gets each table. Other
  // elements of a mixed array are reported by the type check and skipped.
  void read_tables(const toml::table& root, const char* key, void (Loader::*read)(const toml::table&)) {
    const toml::node* n = root.get(key);
    if (n == nullptr) return;
    const auto* arr = n->as_array();
    if (arr == nullptr || !arr->is_array_of_tables()) {
      sink_.add(n->source().begin, std::string(key) + " must be an array of tables ([[" + key + "]]), got " +
                                       std::string(type_name(n->type())));
      if (arr == nullptr) return;
    }
    for (const toml::node& e : *arr) {
      const auto* t = e.as_table();
      if (t == nullptr) continue;
      (this->*read)(*t);
    }
  }

  // The prefix of every message about one [[bus]] or [[device]] entry: its
  // name once it is a string ("bus \"line1\": "), else its position ("bus #2: ").
  static std::string entry_context(std::string_view what, std::size_t ordinal, const toml::node* name_node) {
    if (name_node != nullptr && name_node->is_string()) {
      return std::string(what) + " " + in_quotes(name_node->as_string()->get()) + ": ";
    }
    return std::string(what) + " #" + std::to_string(ordinal) + ": ";
  }

  // An entry's required `name`: an identifier, and where it was written (for
  // the duplicate checks across entries).
  void read_name(TableReader& r, const toml::node* name_node, std::string& name, SourceLocation& spot,
                 bool& has_spot) {
    if (auto v = r.string("name")) {
      if (is_identifier(*v)) {
        name = *v;
        spot = location(sink_, *name_node);
        has_spot = true;
      } else {
        r.error(*name_node, "name " + in_quotes(*v) + " is not allowed (allowed: 1 to 64 of A-Z a-z 0-9 _ - .)");
      }
    } else if (name_node == nullptr) {
      r.missing("name");
    }
  }

  void read_bus(const toml::table& t) {
    Bus bus;
    BusSpots spots;
    bus.where = location(sink_, t);
    const auto* name_node = t.get("name");
    TableReader r(t, "[[bus]]", entry_context("bus", config_.buses.size() + 1, name_node), "", sink_);
    r.check_keys({"name", "interface", "bitrate", "sync_period_ms", "sync_counter", "discovery", "discovery_period_s",
                  "node_pool", "commissioning", "swap_policy", "lss_timeout_ms", "lss_timeout_min_ms", "sdo_timeout_ms",
                  "sdo_retries", "foreign_nmt", "unknown_devices"});
    read_name(r, name_node, bus.name, spots.name, spots.has_name);
    if (auto v = r.string("interface")) {
      if (is_interface_name(*v)) {
        bus.interface = *v;
        spots.interface = location(sink_, *r.find("interface"));
        spots.has_interface = true;
      } else {
        r.error(*r.find("interface"), "interface " + in_quotes(*v) +
                                          " is not a valid Linux interface name (1 to 15 characters, no '/', ':' "
                                          "or white space)");
      }
    } else if (r.find("interface") == nullptr) {
      r.missing("interface");
    }
    if (auto v = r.integer_in("bitrate", {10, 20, 50, 100, 125, 250, 500, 800, 1000})) {
      bus.bitrate_kbit = static_cast<std::uint16_t>(*v);
    }
    // 0x1006 holds the period in microseconds as UNSIGNED32 (CiA 301).
    if (auto v = r.integer("sync_period_ms", 0, kU32 / 1000)) bus.sync_period_ms = static_cast<std::uint32_t>(*v);
    if (auto v = r.integer("sync_counter", 0, 240)) {
      if (*v == 1) {
        r.error(*r.find("sync_counter"), "sync_counter 1 is not allowed (allowed: 0 = no counter, or 2..240; CiA 301 0x1019)");
      } else {
        bus.sync_counter = static_cast<std::uint8_t>(*v);
      }
    }
    if (auto v = r.boolean("discovery")) bus.discovery = *v;
    if (auto v = r.integer("discovery_period_s", 1, 86400)) bus.discovery_period_s = static_cast<std::uint32_t>(*v);
    if (auto v = r.choice<Commissioning>("commissioning", {{"automatic", Commissioning::automatic},
                                                           {"manual", Commissioning::manual},
                                                           {"off", Commissioning::off}})) {
      bus.commissioning = *v;
    }
    read_node_pool(r, bus);
    if (auto v = r.choice<SwapPolicy>("swap_policy", {{"same-model", SwapPolicy::same_model}, {"off", SwapPolicy::off}})) {
      bus.swap_policy = *v;
    }
    if (auto v = r.integer("lss_timeout_ms", 1, 60000)) bus.lss_timeout_ms = static_cast<std::uint32_t>(*v);
    if (auto v = r.integer("lss_timeout_min_ms", 1, 60000)) {
      if (static_cast<std::uint32_t>(*v) > bus.lss_timeout_ms) {
        r.error(*r.find("lss_timeout_min_ms"), "lss_timeout_min_ms " + std::to_string(*v) +
                                                   " is above lss_timeout_ms " + std::to_string(bus.lss_timeout_ms));
      } else {
        bus.lss_timeout_min_ms = static_cast<std::uint32_t>(*v);
      }
    }
    if (auto v = r.integer("sdo_timeout_ms", 1, 60000)) bus.sdo_timeout_ms = static_cast<std::uint32_t>(*v);
    if (auto v = r.integer("sdo_retries", 0, 10)) bus.sdo_retries = static_cast<std::uint8_t>(*v);
    if (auto v = r.choice<ForeignNmt>("foreign_nmt", {{"restart", ForeignNmt::restart}, {"respect", ForeignNmt::respect}})) {
      bus.foreign_nmt = *v;
    }
    if (auto v = r.choice<UnknownDevices>("unknown_devices",
                                          {{"ignore", UnknownDevices::ignore}, {"assign", UnknownDevices::assign}})) {
      bus.unknown_devices = *v;
    }
    config_.buses.push_back(std::move(bus));
    bus_spots_.push_back(spots);
  }

  // ---- [[device]] --------------------------------------------------------

  std::optional<MappingEntry> read_mapping_entry(TableReader& r, const toml::node& item) {
    static constexpr std::array<std::pair<std::string_view, Signal>, 8> kSignals{{{"position", Signal::position},
                                                                                  {"speed", Signal::speed},
                                                                                  {"cam", Signal::cam},
                                                                                  {"work_area", Signal::work_area},
                                                                                  {"alarms", Signal::alarms},
                                                                                  {"warnings", Signal::warnings},
                                                                                  {"temperature", Signal::temperature},
                                                                                  {"voltage", Signal::voltage}}};
    const auto* s = item.as_string();
    if (s == nullptr) {
      r.wrong_type(item, r.path("mapping") + " entry", "a string");
      return std::nullopt;
    }
    const std::string& text = s->get();
    for (const auto& [name, signal] : kSignals) {
      if (name == text) return MappingEntry{signal, 0};
    }
    const bool hex = text.size() == 10 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X') &&
                     std::all_of(text.begin() + 2, text.end(), [](char c) {
                       return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F');
                     });
    if (hex) {
      const auto raw = static_cast<std::uint32_t>(std::stoul(text.substr(2), nullptr, 16));
      const std::uint32_t bits = raw & 0xFFU;
      if (bits == 0 || bits > 64 || (raw >> 16) == 0) {
        r.error(item, r.path("mapping") + " entry " + in_quotes(text) +
                          " is not a valid mapping entry (index must be non-zero, bit length 1..64)");
        return std::nullopt;
      }
      return MappingEntry{Signal::raw, raw};
    }
    r.error(item, r.path("mapping") + " entry " + in_quotes(text) +
                      " is not allowed (allowed: position, speed, cam, work_area, alarms, warnings, temperature, "
                      "voltage, or a raw entry \"0xIIIISSLL\" = index, sub-index, bit length)");
    return std::nullopt;
  }

  std::optional<TpdoSettings> read_tpdo(TableReader& device, std::string_view key) {
    const toml::table* t = device.subtable(key);
    if (t == nullptr) return std::nullopt;
    const std::string k(key);
    TableReader r(*t, "[device." + k + "]", device.context(), k + ".", sink_);
    r.check_keys({"mapping", "transmission", "event_timer_ms", "inhibit_100us"});
    TpdoSettings tpdo;
    if (const toml::array* m = r.array("mapping")) {
      std::vector<MappingEntry> entries;
      bool ok = true;
      std::uint32_t raw_bits = 0;
      for (const toml::node& item : *m) {
        if (auto e = read_mapping_entry(r, item)) {
          entries.push_back(*e);
          if (e->signal == Signal::raw) raw_bits += e->raw & 0xFFU;
        } else {
          ok = false;
        }
      }
      // CiA 301: a PDO carries at most 8 bytes.
      if (entries.size() > 8 || raw_bits > 64) {
        r.error(*r.find("mapping"), r.path("mapping") + " does not fit in a PDO (at most 8 entries and 64 bits)");
        ok = false;
      }
      if (ok) tpdo.mapping = std::move(entries);
    }
    if (const toml::node* n = r.find("transmission")) {
      if (const auto* s = n->as_string()) {
        const std::string& v = s->get();
        if (v == "event") {
          tpdo.transmission = 254;
        } else if (v == "sync") {
          tpdo.transmission = 1;
        } else if (v == "cyclic-measuring") {
          tpdo.transmission = 255;
        } else {
          r.error(*n, r.path("transmission") + " " + in_quotes(v) +
                          " is not allowed (allowed: \"event\", \"sync\", \"cyclic-measuring\", or 0..240, 254, 255)");
        }
      } else if (const auto* i = n->as_integer()) {
        const std::int64_t v = i->get();
        if ((v >= 0 && v <= 240) || v == 254 || v == 255) {
          tpdo.transmission = static_cast<std::uint8_t>(v);
        } else {
          r.error(*n, r.path("transmission") + " " + std::to_string(v) +
                          " is not allowed (allowed: 0..240, 254, 255, \"event\", \"sync\", \"cyclic-measuring\")");
        }
      } else {
        r.wrong_type(*n, r.path("transmission"), "an integer or a string");
      }
    }
    if (auto v = r.integer("event_timer_ms", 0, kU16)) tpdo.event_timer_ms = static_cast<std::uint16_t>(*v);
    if (auto v = r.integer("inhibit_100us", 0, kU16)) tpdo.inhibit_100us = static_cast<std::uint16_t>(*v);
    return tpdo;
  }

  std::optional<Guarding> read_guarding(TableReader& device) {
    const toml::table* t = device.subtable("guarding");
    if (t == nullptr) return std::nullopt;
    TableReader r(*t, "[device.guarding]", device.context(), "guarding.", sink_);
    r.check_keys({"guard_time_ms", "life_time_factor"});
    auto time = r.integer("guard_time_ms", 1, kU16);
    auto factor = r.integer("life_time_factor", 1, kU8);
    if (r.find("guard_time_ms") == nullptr) r.missing("guard_time_ms");
    if (r.find("life_time_factor") == nullptr) r.missing("life_time_factor");
    if (!time || !factor) return std::nullopt;
    return Guarding{static_cast<std::uint16_t>(*time), static_cast<std::uint8_t>(*factor)};
  }

  std::optional<Scaling> read_scaling(TableReader& device) {
    const toml::table* t = device.subtable("scaling");
    if (t == nullptr) return std::nullopt;
    TableReader r(*t, "[device.scaling]", device.context(), "scaling.", sink_);
    r.check_keys({"units_per_rev", "total_range"});
    Scaling s;
    if (auto v = r.integer("units_per_rev", 1, kU32)) s.units_per_rev = static_cast<std::uint32_t>(*v);
    if (auto v = r.integer("total_range", 1, kU32)) s.total_range = static_cast<std::uint32_t>(*v);
    return s;
  }

  std::optional<WorkArea> read_work_area(TableReader& device) {
    const toml::table* t = device.subtable("work_area");
    if (t == nullptr) return std::nullopt;
    TableReader r(*t, "[device.work_area]", device.context(), "work_area.", sink_);
    r.check_keys({"low", "high"});
    WorkArea w;
    if (auto v = r.integer("low", kI32Min, kI32Max)) w.low = static_cast<std::int32_t>(*v);
    if (auto v = r.integer("high", kI32Min, kI32Max)) w.high = static_cast<std::int32_t>(*v);
    return w;
  }

  void read_cams(TableReader& device, Device& d, std::int64_t max_index) {
    const toml::node* n = device.find("cam");
    if (n == nullptr) return;
    const auto* arr = n->as_array();
    if (arr == nullptr || !arr->is_array_of_tables()) {
      device.wrong_type(*n, "cam", "an array of tables ([[device.cam]])");
      return;
    }
    std::array<const toml::node*, 9> seen{};
    for (const toml::node& e : *arr) {
      const auto& t = *e.as_table();
      TableReader r(t, "[[device.cam]]", device.context(), "cam.", sink_);
      r.check_keys({"index", "low", "high", "hysteresis", "enabled", "polarity"});
      Cam cam;
      const auto index = r.integer("index", 1, max_index);
      if (r.find("index") == nullptr) r.missing("index");
      if (index) {
        const auto i = static_cast<std::size_t>(*index);
        if (seen[i] != nullptr) {
          r.error(*r.find("index"), "cam index " + std::to_string(i) + " is defined twice (first at " +
                                        at(location(sink_, *seen[i])) + ")");
        } else {
          seen[i] = r.find("index");
        }
        cam.index = static_cast<std::uint8_t>(*index);
      }
      // The widest of the families' limit types: INTEGER32 (J) and
      // UNSIGNED32 (F§7.5 0x631x); the gateway narrows it per object.
      if (auto v = r.integer("low", kI32Min, kU32)) cam.low = *v;
      if (auto v = r.integer("high", kI32Min, kU32)) cam.high = *v;
      // INTEGER16 on the rotary series (J 0x633x), UNSIGNED16 (E), u32 (F):
      // 0..32767 is valid everywhere.
      if (auto v = r.integer("hysteresis", 0, 32767)) cam.hysteresis = static_cast<std::uint16_t>(*v);
      cam.enabled = r.boolean("enabled");
      cam.polarity = r.choice<CamPolarity>("polarity", {{"normal", CamPolarity::normal}, {"inverted", CamPolarity::inverted}});
      if (index) d.cams.push_back(cam);
    }
    std::sort(d.cams.begin(), d.cams.end(), [](const Cam& a, const Cam& b) { return a.index < b.index; });
  }

  void read_device(const toml::table& t) {
    Device d;
    DeviceSpots spots;
    d.where = location(sink_, t);
    const toml::node* name_node = t.get("name");
    TableReader r(t, "[[device]]", entry_context("device", config_.devices.size() + 1, name_node), "", sink_);
    r.check_keys({"name", "bus", "serial", "vendor", "product", "node_id", "model", "channels", "eds", "tpdo1", "tpdo2",
                  "heartbeat_ms", "guarding", "direction", "scaling", "preset", "cam", "work_area", "position_filter",
                  "speed_filter", "store"});

    read_name(r, name_node, d.name, spots.name, spots.has_name);
    if (auto v = r.string("bus")) {
      d.bus = *v;
      spots.bus = location(sink_, *r.find("bus"));
      spots.has_bus = true;
    } else if (r.find("bus") == nullptr) {
      r.missing("bus");
    }
    if (auto v = r.integer("serial", 0, kU32)) {
      d.serial = static_cast<std::uint32_t>(*v);
      spots.serial = location(sink_, *r.find("serial"));
      spots.has_serial = true;
    } else if (r.find("serial") == nullptr) {
      r.missing("serial");
    }
    if (auto v = r.integer("vendor", 0, kU32)) d.vendor = static_cast<std::uint32_t>(*v);
    if (auto v = r.integer("product", 0, kU32)) d.product = static_cast<std::uint32_t>(*v);
    if (auto v = r.integer("node_id", 1, 127)) {
      d.node_id = static_cast<std::uint8_t>(*v);
      spots.node_id = location(sink_, *r.find("node_id"));
    }

    const KnownModel* model = nullptr;
    if (auto v = r.string("model")) {
      model = find_model(*v);
      if (model != nullptr) {
        d.model = *v;
      } else {
        std::string names;
        for (const auto& m : known_models()) {
          if (!names.empty()) names += ", ";
          names += m.name;
        }
        r.error(*r.find("model"), "model " + in_quotes(*v) + " is not known (allowed: " + names + "; or give eds = \"path\")");
      }
    }
    if (auto v = r.string("eds")) {
      if (r.find("model") != nullptr) {
        r.error(*r.find("eds"), "give either model or eds, not both");
      } else {
        check_eds(r, d, *v);
      }
    }
    if (model != nullptr) check_identity(r, d, *model);

    if (auto v = r.integer("channels", 1, 2)) {
      if (model == nullptr || model->max_channels < 2) {
        r.error(*r.find("channels"), "channels is only allowed with a model of the rotary series (RFC-4800, RSA-3200, "
                                     "RFE-3200, RSX-7900, RFX-6900)");
      } else {
        d.channels = static_cast<std::uint8_t>(*v);
      }
    }

    d.tpdo1 = read_tpdo(r, "tpdo1");
    d.tpdo2 = read_tpdo(r, "tpdo2");
    if (auto v = r.integer("heartbeat_ms", 0, kU16)) d.heartbeat_ms = static_cast<std::uint16_t>(*v);
    d.guarding = read_guarding(r);
    if (r.find("heartbeat_ms") != nullptr && r.find("guarding") != nullptr) {
      // CiA 301 §7.2.8.3.2: a node produces heartbeats or answers node
      // guarding, not both; configuring both would leave it to the device.
      r.error(*r.find("guarding"), "give either heartbeat_ms or [device.guarding], not both");
    }
    d.direction = r.choice<Direction>("direction", {{"cw", Direction::cw}, {"ccw", Direction::ccw}});
    d.scaling = read_scaling(r);
    read_preset(r, d, model);

    std::int64_t max_cam = 8;
    if (model != nullptr) {
      const std::uint8_t channels = d.channels.value_or(model->max_channels);
      max_cam = static_cast<std::int64_t>(model->cams_per_channel) * channels;
    }
    read_cams(r, d, max_cam);
    d.work_area = read_work_area(r);

    if (auto v = r.integer("position_filter", 0, 7)) {
      if (model != nullptr && !model->position_filter) {
        r.error(*r.find("position_filter"), "position_filter is not supported by model " + in_quotes(model->name));
      } else {
        d.position_filter = static_cast<std::uint8_t>(*v);
      }
    }
    if (auto v = r.integer("speed_filter", 0, 8)) {
      if (model != nullptr && !model->speed_filter) {
        r.error(*r.find("speed_filter"), "speed_filter is not supported by model " + in_quotes(model->name) +
                                             " (only by the multiturn series MZ1-2200, MC1-2800, MB1-3600)");
      } else {
        d.speed_filter = static_cast<std::uint8_t>(*v);
      }
    }
    if (auto v = r.choice<StorePolicy>(
            "store", {{"on-change", StorePolicy::on_change}, {"always", StorePolicy::always}, {"never", StorePolicy::never}})) {
      d.store = *v;
    }
    config_.devices.push_back(std::move(d));
    device_spots_.push_back(spots);
  }

  void check_eds(TableReader& r, Device& d, const std::string& value) {
    const toml::node& n = *r.find("eds");
    if (value.empty()) {
      r.error(n, "eds must name a file, got \"\"");
      return;
    }
    const fs::path path = resolve(value);
    std::error_code ec;
    const auto status = fs::status(path, ec);
    if (ec || !fs::exists(status)) {
      r.error(n, "eds file " + in_quotes(path.string()) + " does not exist");
    } else if (!fs::is_regular_file(status)) {
      r.error(n, "eds file " + in_quotes(path.string()) + " is not a regular file");
    } else if (::access(path.c_str(), R_OK) != 0) {
      r.error(n, "eds file " + in_quotes(path.string()) + " is not readable: " + std::strerror(errno));
    } else {
      d.eds = path;
    }
  }

  void check_identity(TableReader& r, const Device& d, const KnownModel& model) {
    if (d.vendor && *d.vendor != model.vendor) {
      r.error(*r.find("vendor"), "vendor " + hex32(*d.vendor) + " does not match model " + in_quotes(model.name) +
                                     " (vendor " + hex32(model.vendor) + ")");
    }
    if (d.product && !model.products.empty() &&
        std::find(model.products.begin(), model.products.end(), *d.product) == model.products.end()) {
      std::string codes;
      for (const auto p : model.products) {
        if (!codes.empty()) codes += ", ";
        codes += hex32(p);
      }
      r.error(*r.find("product"), "product " + hex32(*d.product) + " does not match model " + in_quotes(model.name) +
                                      " (allowed: " + codes + ")");
    }
  }

  void read_preset(TableReader& r, Device& d, const KnownModel* model) {
    // INTEGER32 on the rotary series (J 0x6010), UNSIGNED32 on the others
    // (E, F 0x6003); unknown models get the union.
    std::int64_t min = kI32Min;
    std::int64_t max = kU32;
    if (model != nullptr) {
      if (model->family == Family::novotechnik_rotary) {
        max = kI32Max;
      } else {
        min = 0;
      }
    }
    if (auto v = r.integer("preset", min, max)) d.preset = *v;
  }

  // ---- [outputs.<name>] --------------------------------------------------

  void read_outputs(TableReader& top) {
    const toml::table* outputs = top.subtable("outputs");
    if (outputs == nullptr) return;
    std::vector<const toml::key*> keys;
    for (auto&& [key, value] : *outputs) keys.push_back(&key);
    std::sort(keys.begin(), keys.end(),
              [](const toml::key* a, const toml::key* b) { return a->source().begin < b->source().begin; });
    for (const toml::key* key : keys) {
      const std::string name(key->str());
      const toml::node& value = *outputs->get(name);
      const auto* t = value.as_table();
      if (t == nullptr) {
        sink_.add(value.source().begin, "outputs." + name + " must be a table ([outputs." + name + "]), got " +
                                            std::string(type_name(value.type())));
        continue;
      }
      if (!is_identifier(name)) {
        sink_.add(key->source().begin,
                  "output name " + in_quotes(name) + " is not allowed (allowed: 1 to 64 of A-Z a-z 0-9 _ - .)");
        continue;
      }
      TableReader r(*t, "[outputs." + name + "]", "", "outputs." + name + ".", sink_);
      Output out;
      out.name = name;
      out.where = location(sink_, *t);
      if (auto v = r.boolean("enabled")) out.enabled = *v;
      if (auto v = r.string("plugin")) {
        if (v->empty()) {
          r.error(*r.find("plugin"), r.path("plugin") + " must name a file, got \"\"");
        } else {
          out.plugin = *v;
        }
      }
      toml::table rest = *t;
      rest.erase("enabled");
      rest.erase("plugin");
      std::ostringstream os;
      os << toml::toml_formatter{rest};
      out.settings_toml = os.str();
      config_.outputs.push_back(std::move(out));
    }
  }

  // ---- [web] -------------------------------------------------------------

  void read_web(TableReader& top) {
    const toml::table* t = top.subtable("web");
    if (t == nullptr) return;
    TableReader r(*t, "[web]", "", "web.", sink_);
    r.check_keys({"enabled", "bind", "port", "tls_cert", "tls_key", "auth_file", "max_clients", "timeout_s"});
    WebSettings w;
    w.where = location(sink_, *t);
    if (auto v = r.boolean("enabled")) w.enabled = *v;
    if (auto v = r.string("bind")) {
      in6_addr a6{};
      in_addr a4{};
      if (::inet_pton(AF_INET, v->c_str(), &a4) == 1 || ::inet_pton(AF_INET6, v->c_str(), &a6) == 1) {
        w.bind = *v;
      } else {
        r.error(*r.find("bind"), "web.bind " + in_quotes(*v) +
                                     " is not an IP address (e.g. \"127.0.0.1\", \"0.0.0.0\", \"::1\")");
      }
    }
    if (auto v = r.integer("port", 1, 65535)) w.port = static_cast<std::uint16_t>(*v);
    if (auto v = r.integer("max_clients", 1, 1024)) w.max_clients = static_cast<std::uint32_t>(*v);
    if (auto v = r.integer("timeout_s", 1, 3600)) w.timeout_s = static_cast<std::uint32_t>(*v);
    auto file = [&](std::string_view key, fs::path& out, SourceLocation& at) {
      const auto v = r.string(key);
      if (!v) return;
      at = location(sink_, *r.find(key));
      if (v->empty()) {
        r.error(*r.find(key), r.path(key) + " must name a file, got \"\"");
        return;
      }
      out = resolve(*v);
    };
    file("tls_cert", w.tls_cert, w.tls_cert_at);
    file("tls_key", w.tls_key, w.tls_key_at);
    file("auth_file", w.auth_file, w.auth_file_at);
    if (w.tls_cert.empty() != w.tls_key.empty()) {
      const bool has_cert = !w.tls_cert.empty();
      r.error(*r.find(has_cert ? "tls_cert" : "tls_key"),
              std::string("web.") + (has_cert ? "tls_cert" : "tls_key") + " is set but web." +
                  (has_cert ? "tls_key" : "tls_cert") + " is not (TLS needs both)");
    }
    config_.web = std::move(w);
  }

  // ---- checks across sections ---------------------------------------------

  void cross_check() {
    std::map<std::string, std::size_t> bus_by_name;
    std::map<std::string, std::size_t> bus_by_interface;
    for (std::size_t i = 0; i < config_.buses.size(); ++i) {
      const Bus& b = config_.buses[i];
      const BusSpots& s = bus_spots_[i];
      if (s.has_name) {
        auto [it, fresh] = bus_by_name.emplace(b.name, i);
        if (!fresh) {
          add(s.name, "duplicate bus name " + in_quotes(b.name) + " (first defined at " + at(bus_spots_[it->second].name) + ")");
        }
      }
      if (s.has_interface) {
        auto [it, fresh] = bus_by_interface.emplace(b.interface, i);
        if (!fresh) {
          add(s.interface, "bus " + in_quotes(b.name) + ": interface " + in_quotes(b.interface) + " is already used by bus " +
                               in_quotes(config_.buses[it->second].name) + " (" + at(bus_spots_[it->second].interface) + ")");
        }
      }
    }

    std::map<std::string, std::size_t> device_by_name;
    std::map<std::pair<std::size_t, std::uint8_t>, std::size_t> device_by_node;
    for (std::size_t i = 0; i < config_.devices.size(); ++i) {
      Device& d = config_.devices[i];
      const DeviceSpots& s = device_spots_[i];
      const std::string ctx = "device " + in_quotes(d.name) + ": ";
      if (s.has_name) {
        auto [it, fresh] = device_by_name.emplace(d.name, i);
        if (!fresh) {
          add(s.name, "duplicate device name " + in_quotes(d.name) + " (first defined at " +
                          at(device_spots_[it->second].name) + ")");
        }
      }
      if (!s.has_bus) continue;
      const auto bus = bus_by_name.find(d.bus);
      if (bus == bus_by_name.end()) {
        std::string names;
        for (const auto& [name, index] : bus_by_name) names += (names.empty() ? "" : ", ") + name;
        add(s.bus, ctx + "bus " + in_quotes(d.bus) + " is not defined (defined buses: " + (names.empty() ? "none" : names) + ")");
        continue;
      }
      d.bus_index = bus->second;
      if (d.node_id) {
        auto [it, fresh] = device_by_node.emplace(std::make_pair(d.bus_index, *d.node_id), i);
        if (!fresh) {
          add(s.node_id, ctx + "node_id " + std::to_string(*d.node_id) + " is already used by device " +
                             in_quotes(config_.devices[it->second].name) + " on bus " + in_quotes(d.bus) + " (" +
                             at(device_spots_[it->second].node_id) + ")");
        }
      }
    }

    // Serial numbers are unique per vendor (CiA 301 0x1018): the same serial
    // is a conflict unless both vendors are known and differ.
    for (std::size_t i = 0; i < config_.devices.size(); ++i) {
      const Device& d = config_.devices[i];
      if (!device_spots_[i].has_serial) continue;
      for (std::size_t j = 0; j < i; ++j) {
        const Device& first = config_.devices[j];
        if (!device_spots_[j].has_serial || first.serial != d.serial) continue;
        const auto va = vendor_of(d);
        const auto vb = vendor_of(first);
        if (va && vb && *va != *vb) continue;
        add(device_spots_[i].serial, "device " + in_quotes(d.name) + ": serial " + std::to_string(d.serial) +
                                         " is already used by device " + in_quotes(first.name) + " (" +
                                         at(device_spots_[j].serial) + ")");
        break;
      }
    }
  }

  static std::optional<std::uint32_t> vendor_of(const Device& d) {
    if (d.vendor) return d.vendor;
    if (const KnownModel* m = find_model(d.model)) return m->vendor;
    return std::nullopt;
  }

  void add(const SourceLocation& where, std::string message) { sink_.add(where.line, where.column, std::move(message)); }

  DiagnosticSink sink_;
  fs::path base_dir_;
  Config config_;
  std::vector<BusSpots> bus_spots_;
  std::vector<DeviceSpots> device_spots_;
};

LoadResult internal_error(std::string_view file, const char* what) noexcept {
  try {
    return LoadResult(std::vector<Diagnostic>{Diagnostic{std::string(file), 0, 0, std::string("internal error: ") + what}});
  } catch (...) {
    return LoadResult(std::vector<Diagnostic>{});
  }
}

}  // namespace

LoadResult load_string(std::string_view text, std::string_view file_name, const fs::path& base_dir) noexcept {
  try {
    Loader loader(file_name, base_dir);
    return loader.run(text);
  } catch (const std::exception& e) {
    return internal_error(file_name, e.what());
  } catch (...) {
    return internal_error(file_name, "unknown exception");
  }
}

LoadResult load(const fs::path& path) noexcept {
  try {
    // An ifstream opens a directory and then reads nothing, which would
    // pass for an empty (valid) file.
    std::error_code ec;
    if (fs::is_directory(path, ec)) {
      return LoadResult(std::vector<Diagnostic>{
          Diagnostic{path.string(), 0, 0, "cannot read the configuration file: it is a directory"}});
    }
    std::ifstream in(path, std::ios::binary);
    if (!in) {
      const int err = errno;
      return LoadResult(std::vector<Diagnostic>{
          Diagnostic{path.string(), 0, 0, std::string("cannot open the configuration file: ") + std::strerror(err)}});
    }
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad()) {
      return LoadResult(std::vector<Diagnostic>{Diagnostic{path.string(), 0, 0, "cannot read the configuration file"}});
    }
    fs::path base = path.parent_path();
    if (base.empty()) base = ".";
    return load_string(text.str(), path.string(), base);
  } catch (const std::exception& e) {
    return internal_error(path.native(), e.what());
  } catch (...) {
    return internal_error(path.native(), "unknown exception");
  }
}

}  // namespace cobridge::config
