// Tests of the configuration loader: the shipped example loads with the
// values it states, every bad_* fixture is rejected with the exact
// file:line:column and message, defaults are applied, and no input (random
// bytes, truncations, mutations) makes it throw or crash.
//
// The schema is specified in docs/configuration.md ("doc §<section>" below);
// range limits that come from the manuals or CiA 301 cite those.
#include "config/known_models.hpp"
#include "config/load.hpp"
#include "sys/install_paths.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace cobridge::config {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

const fs::path kRepo = fs::path(__FILE__).parent_path().parent_path().parent_path().parent_path();

// The installed device directory beside the running executable, as the
// loader puts it first in gateway.device_dirs; none in a build tree.
std::vector<fs::path> installed_device_dirs() {
  const fs::path d = cobridge::sys::installed_or(cobridge::sys::InstallDir::devices, {});
  return d.empty() ? std::vector<fs::path>{} : std::vector<fs::path>{d};
}
const fs::path kFixtures = fs::path(__FILE__).parent_path() / "fixtures";
const fs::path kExample = kRepo / "config" / "cobridge.toml";

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

struct Expected {
  std::uint32_t line;
  std::uint32_t column;
  std::string fragment;
};

// Asserts that the fixture fails with exactly these diagnostics, in order.
void expect_diagnostics(const std::string& fixture, const std::vector<Expected>& expected) {
  const fs::path path = kFixtures / fixture;
  ASSERT_TRUE(fs::exists(path)) << path;
  const LoadResult r = load(path);
  ASSERT_FALSE(r.ok()) << fixture << " loaded without errors";
  const auto& d = r.diagnostics();
  std::string all;
  for (const auto& x : d) all += to_string(x) + "\n";
  ASSERT_EQ(d.size(), expected.size()) << all;
  for (std::size_t i = 0; i < d.size(); ++i) {
    SCOPED_TRACE(to_string(d[i]));
    EXPECT_EQ(d[i].file, path.string());
    EXPECT_EQ(d[i].line, expected[i].line);
    EXPECT_EQ(d[i].column, expected[i].column);
    EXPECT_THAT(d[i].message, HasSubstr(expected[i].fragment));
  }
}

// ---- the shipped example ---------------------------------------------------

// doc §[gateway], §[logging]
TEST(ConfigExample, LoadsGatewayAndLogging) {
  const LoadResult r = load(kExample);
  std::string all;
  for (const auto& x : r.diagnostics()) all += to_string(x) + "\n";
  ASSERT_TRUE(r.ok()) << all;
  const Config& c = r.config();
  EXPECT_EQ(c.source, kExample);
  EXPECT_EQ(c.gateway.id, "cell-7-gw");
  EXPECT_EQ(c.gateway.state_dir, "/var/lib/cobridge");
  EXPECT_EQ(c.gateway.control_socket, "/run/cobridge/control.sock");
  const auto installed = installed_device_dirs();
  ASSERT_EQ(c.gateway.device_dirs.size(), installed.size() + 1);
  if (!installed.empty()) {
    EXPECT_EQ(c.gateway.device_dirs[0], installed[0]);  // the installed one first
  }
  EXPECT_TRUE(fs::equivalent(c.gateway.device_dirs.back(), kRepo / "config" / "devices"));
  EXPECT_EQ(c.logging.level, LogLevel::info);
  EXPECT_EQ(c.logging.target, LogTarget::automatic);
  ASSERT_EQ(c.logging.modules.size(), 2U);
  EXPECT_EQ(c.logging.modules[0], std::make_pair(std::string("canopen"), LogLevel::debug));
  EXPECT_EQ(c.logging.modules[1], std::make_pair(std::string("modbus"), LogLevel::warn));
}

// doc §[gateway] device_dirs: one directory named twice, by
// another spelling, is loaded once; its files are not duplicates of themselves.
TEST(ConfigGateway, ADeviceDirectoryNamedTwiceIsListedOnce) {
  const std::string base = kExample.parent_path().string();
  const std::string abs = (kRepo / "config" / "devices").string();
  const LoadResult r =
      load_string("[gateway]\ndevice_dirs = [\"devices\", \"./devices/\", \"" + abs + "\"]\n", "twice.toml", base);
  ASSERT_TRUE(r.ok());
  const auto installed = installed_device_dirs();
  ASSERT_EQ(r.config().gateway.device_dirs.size(), installed.size() + 1);
  EXPECT_TRUE(fs::equivalent(r.config().gateway.device_dirs.back(), abs));
}

// doc §[[bus]]; sync counter 0 or 2..240 per CiA 301 0x1019
TEST(ConfigExample, LoadsTwoBuses) {
  const LoadResult r = load(kExample);
  ASSERT_TRUE(r.ok());
  const Config& c = r.config();
  ASSERT_EQ(c.buses.size(), 2U);
  const Bus& a = c.buses[0];
  EXPECT_EQ(a.name, "line1");
  EXPECT_EQ(a.interface, "can0");
  EXPECT_EQ(a.bitrate_kbit, 250);
  EXPECT_EQ(a.sync_period_ms, 10U);
  EXPECT_EQ(a.sync_counter, 0);
  EXPECT_TRUE(a.discovery);
  EXPECT_EQ(a.discovery_period_s, 30U);
  ASSERT_EQ(a.node_pool.size(), 51U);
  EXPECT_EQ(a.node_pool.front(), 10);
  EXPECT_EQ(a.node_pool.back(), 60);
  EXPECT_EQ(a.commissioning, Commissioning::automatic);
  EXPECT_EQ(a.swap_policy, SwapPolicy::same_model);
  EXPECT_EQ(a.lss_timeout_ms, 100U);
  EXPECT_EQ(a.sdo_timeout_ms, 500U);
  EXPECT_EQ(a.sdo_retries, 2);
  EXPECT_EQ(a.where.line, 28U);  // the [[bus]] header

  const Bus& b = c.buses[1];
  EXPECT_EQ(b.name, "line2");
  EXPECT_EQ(b.bitrate_kbit, 125);
  EXPECT_EQ(b.sync_period_ms, 0U);
  EXPECT_FALSE(b.discovery);
  std::vector<std::uint8_t> pool{100};
  for (std::uint8_t id = 110; id <= 119; ++id) pool.push_back(id);
  EXPECT_EQ(b.node_pool, pool);
  EXPECT_EQ(b.commissioning, Commissioning::manual);
  EXPECT_EQ(b.swap_policy, SwapPolicy::off);
  EXPECT_EQ(c.find_bus("line2"), &b);
  EXPECT_EQ(c.find_bus("line3"), nullptr);
}

// J§1.3.1 (TPDO types 254/255, 2 channels, CAMs per channel J§1.4.5)
TEST(ConfigExample, LoadsRotaryDeviceSettings) {
  const LoadResult r = load(kExample);
  ASSERT_TRUE(r.ok());
  const Config& c = r.config();
  ASSERT_EQ(c.devices.size(), 6U);
  const Device* d = c.find_device("turntable");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->bus, "line1");
  EXPECT_EQ(d->bus_index, 0U);
  EXPECT_EQ(d->serial, 40012U);
  EXPECT_EQ(d->model, "RFC-4800");
  EXPECT_EQ(d->channels, std::optional<std::uint8_t>(2));
  EXPECT_EQ(d->node_id, std::optional<std::uint8_t>(10));
  EXPECT_EQ(d->heartbeat_ms, std::optional<std::uint16_t>(100));
  EXPECT_FALSE(d->guarding.has_value());
  EXPECT_EQ(d->direction, Direction::cw);
  EXPECT_EQ(d->position_filter, std::optional<std::uint8_t>(2));
  EXPECT_EQ(d->store, StorePolicy::on_change);
  ASSERT_TRUE(d->tpdo1.has_value());
  EXPECT_EQ(d->tpdo1->mapping,
            (std::vector<MappingEntry>{{Signal::position, 0}, {Signal::speed, 0}}));
  EXPECT_EQ(d->tpdo1->transmission, std::optional<std::uint8_t>(254));
  EXPECT_EQ(d->tpdo1->event_timer_ms, std::optional<std::uint16_t>(10));
  EXPECT_EQ(d->tpdo1->inhibit_100us, std::optional<std::uint16_t>(0));
  ASSERT_TRUE(d->tpdo2.has_value());
  EXPECT_EQ(d->tpdo2->transmission, std::optional<std::uint8_t>(1));
  EXPECT_FALSE(d->tpdo2->event_timer_ms.has_value());
  ASSERT_EQ(d->cams.size(), 2U);
  EXPECT_EQ(d->cams[0].index, 1);
  EXPECT_EQ(d->cams[0].low, std::optional<std::int64_t>(1000));
  EXPECT_EQ(d->cams[0].hysteresis, std::optional<std::uint16_t>(10));
  EXPECT_FALSE(d->cams[0].enabled.has_value());
  EXPECT_EQ(d->cams[1].index, 5);
  EXPECT_EQ(d->cams[1].high, std::optional<std::int64_t>(500));
  EXPECT_EQ(d->cams[1].polarity, CamPolarity::inverted);
  ASSERT_TRUE(d->work_area.has_value());
  EXPECT_EQ(d->work_area->high, std::optional<std::int32_t>(16383));

  const Device* g = c.find_device("lift-arm");
  ASSERT_NE(g, nullptr);
  ASSERT_TRUE(g->guarding.has_value());
  EXPECT_EQ(g->guarding->guard_time_ms, 200);
  EXPECT_EQ(g->guarding->life_time_factor, 3);
  EXPECT_FALSE(g->heartbeat_ms.has_value());
  EXPECT_EQ(g->tpdo1->transmission, std::optional<std::uint8_t>(1));
}

// E§5.1, E§5.2 (filters), E§4.1 (scaling 0x6001/0x6002), F§7.3 (TPDO1)
TEST(ConfigExample, LoadsMultiturnAndIfmDevices) {
  const LoadResult r = load(kExample);
  ASSERT_TRUE(r.ok());
  const Config& c = r.config();
  const Device* w = c.find_device("winch");
  ASSERT_NE(w, nullptr);
  EXPECT_EQ(w->direction, Direction::ccw);
  EXPECT_EQ(w->preset, std::optional<std::int64_t>(0));
  EXPECT_EQ(w->speed_filter, std::optional<std::uint8_t>(3));
  ASSERT_TRUE(w->scaling.has_value());
  EXPECT_EQ(w->scaling->units_per_rev, std::optional<std::uint32_t>(4096));
  EXPECT_EQ(w->scaling->total_range, std::optional<std::uint32_t>(180224));
  EXPECT_EQ(w->tpdo1->transmission, std::optional<std::uint8_t>(255));

  const Device* h = c.find_device("hoist");
  ASSERT_NE(h, nullptr);
  EXPECT_FALSE(h->node_id.has_value());  // assigned from the pool

  const Device* conv = c.find_device("conveyor");
  ASSERT_NE(conv, nullptr);
  EXPECT_EQ(conv->bus_index, 1U);
  EXPECT_EQ(conv->tpdo1->mapping,
            (std::vector<MappingEntry>{{Signal::position, 0}, {Signal::raw, 0x60300110U}}));
  ASSERT_EQ(conv->cams.size(), 1U);
  EXPECT_EQ(conv->cams[0].index, 8);  // F§7.5: CAMs 1..8

  const Device* f = c.find_device("feeder");
  ASSERT_NE(f, nullptr);
  EXPECT_TRUE(f->model.empty());
  EXPECT_EQ(f->vendor, std::optional<std::uint32_t>(0x0069666DU));
  EXPECT_TRUE(f->eds.is_absolute() || f->eds.has_parent_path());
  EXPECT_TRUE(fs::equivalent(f->eds, kRepo / "config" / "devices" / "ifm-rm8-rm9.eds"));
  EXPECT_EQ(f->store, StorePolicy::never);
}

// doc §[outputs.<name>]
TEST(ConfigExample, KeepsOutputSectionsOpaque) {
  const LoadResult r = load(kExample);
  ASSERT_TRUE(r.ok());
  const Config& c = r.config();
  ASSERT_EQ(c.outputs.size(), 4U);
  EXPECT_EQ(c.outputs[0].name, "dds");  // file order
  EXPECT_EQ(c.outputs[1].name, "modbus");
  EXPECT_EQ(c.outputs[2].name, "mqtt");
  EXPECT_FALSE(c.outputs[2].enabled);  // the Sparkplug output is shown, off by default
  EXPECT_EQ(c.outputs[3].name, "jsontap");
  const Output* dds = c.find_output("dds");
  EXPECT_TRUE(dds->enabled);
  EXPECT_TRUE(dds->plugin.empty());
  EXPECT_THAT(dds->settings_toml, HasSubstr("domain = 0"));
  EXPECT_THAT(dds->settings_toml, HasSubstr("sample_reliability = 'best-effort'"));
  EXPECT_THAT(dds->settings_toml, ::testing::Not(HasSubstr("enabled")));
  EXPECT_GT(dds->where.line, 0U);
  const Output* tap = c.find_output("jsontap");
  EXPECT_FALSE(tap->enabled);
  EXPECT_EQ(tap->plugin, "libcobridge_jsontap.so");
  EXPECT_THAT(tap->settings_toml, ::testing::Not(HasSubstr("plugin")));
  // The settings text is valid TOML for the plugin to parse again.
  const LoadResult again = load_string("[outputs.x]\n" + tap->settings_toml, "again.toml");
  EXPECT_TRUE(again.ok());
}

// Plugins load from the plugin directory only: `plugin`
// names a file there, never a path.
TEST(ConfigOutputs, PluginIsAFileNameNotAPath) {
  for (const char* bad : {"/tmp/evil.so", "../lib/x.so", "sub/x.so", ".."}) {
    const LoadResult r = load_string(std::string("[outputs.tap]\nplugin = \"") + bad + "\"\n", "p.toml");
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_EQ(r.diagnostics()[0].line, 2U);
    EXPECT_THAT(r.diagnostics()[0].message, HasSubstr("must be a file name in the plugin directory, not a path"));
  }
  EXPECT_TRUE(load_string("[outputs.tap]\nplugin = \"libcobridge_jsontap.so\"\n", "p.toml").ok());
}

// ---- defaults ----------------------------------------------------------------

// doc §[gateway], §[[bus]], §[[device]]: defaults
TEST(ConfigDefaults, AppliedWhenKeysAreLeftOut) {
  const LoadResult r = load(kFixtures / "good_minimal.toml");
  ASSERT_TRUE(r.ok());
  const Config& c = r.config();
  std::array<char, 256> host{};
  ASSERT_EQ(::gethostname(host.data(), host.size() - 1), 0);
  EXPECT_EQ(c.gateway.id, std::string(host.data()));
  EXPECT_EQ(c.gateway.state_dir, "/var/lib/cobridge");
  // Only the installed descriptions, when the executable has an installed tree around it.
  EXPECT_EQ(c.gateway.device_dirs, installed_device_dirs());
  EXPECT_EQ(c.gateway.control_socket, "/run/cobridge/control.sock");
  EXPECT_EQ(c.logging.level, LogLevel::info);
  EXPECT_EQ(c.logging.target, LogTarget::automatic);
  EXPECT_TRUE(c.logging.modules.empty());

  ASSERT_EQ(c.buses.size(), 1U);
  const Bus& b = c.buses[0];
  EXPECT_EQ(b.bitrate_kbit, 125);
  EXPECT_EQ(b.sync_period_ms, 0U);
  EXPECT_EQ(b.sync_counter, 0);
  EXPECT_TRUE(b.discovery);
  EXPECT_EQ(b.discovery_period_s, 10U);
  ASSERT_EQ(b.node_pool.size(), 127U);  // CiA 301 §7.3.2: node-IDs 1..127
  EXPECT_EQ(b.node_pool.front(), 1);
  EXPECT_EQ(b.node_pool.back(), 127);
  EXPECT_EQ(b.commissioning, Commissioning::automatic);
  EXPECT_EQ(b.swap_policy, SwapPolicy::same_model);
  EXPECT_EQ(b.lss_timeout_ms, 100U);
  EXPECT_EQ(b.sdo_timeout_ms, 500U);
  EXPECT_EQ(b.sdo_retries, 2);

  ASSERT_EQ(c.devices.size(), 1U);
  const Device& d = c.devices[0];
  EXPECT_EQ(d.serial, 1U);
  EXPECT_FALSE(d.node_id || d.vendor || d.product || d.channels || d.tpdo1 || d.tpdo2 || d.heartbeat_ms ||
               d.guarding || d.direction || d.scaling || d.preset || d.work_area || d.position_filter ||
               d.speed_filter);
  EXPECT_TRUE(d.model.empty());
  EXPECT_TRUE(d.eds.empty());
  EXPECT_TRUE(d.cams.empty());
  EXPECT_EQ(d.store, StorePolicy::on_change);
  EXPECT_TRUE(c.outputs.empty());
}

// doc §[[bus]] node_pool
TEST(ConfigDefaults, NodePoolForms) {
  const LoadResult r = load(kFixtures / "good_node_pool_forms.toml");
  ASSERT_TRUE(r.ok());
  const Config& c = r.config();
  EXPECT_EQ(c.buses[0].node_pool, (std::vector<std::uint8_t>{5}));
  EXPECT_EQ(c.buses[1].node_pool, (std::vector<std::uint8_t>{1, 3, 4, 127}));
  EXPECT_TRUE(c.buses[2].node_pool.empty());
}

// doc §Files: an empty file is a gateway without buses
TEST(ConfigDefaults, EmptyFileIsValid) {
  const LoadResult r = load_string("", "empty.toml");
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r.config().buses.empty());
}

// ---- bad fixtures ----------------------------------------------------------------

// doc §Errors: wrong types name the expected and the actual TOML type
TEST(ConfigErrors, WrongTypes) {
  expect_diagnostics("bad_wrong_types.toml",
                     {{2, 15, "gateway.device_dirs must be an array, got string"},
                      {7, 11, "bus \"line1\": bitrate must be an integer, got string"},
                      {8, 13, "bus \"line1\": discovery must be a boolean, got integer"},
                      {13, 10, "device \"enc\": serial must be an integer, got float"},
                      {14, 11, "device \"enc\": node_id must be an integer, got string"},
                      {15, 16, "device \"enc\": heartbeat_ms must be an integer, got boolean"},
                      {18, 11, "device \"enc\": tpdo1.mapping must be an array, got string"}});
}

// doc §Errors: unknown keys are errors, listing the allowed keys
TEST(ConfigErrors, UnknownKeys) {
  expect_diagnostics(
      "bad_unknown_keys.toml",
      {{2, 1, "unknown key \"ident\" in [gateway] (allowed: id, state_dir, device_dirs, control_socket)"},
       {7, 1, "unknown key \"bitrat\" in [[bus]] (allowed: name, interface, bitrate, sync_period_ms"},
       {16, 1, "unknown key \"event_timer\" in [device.tpdo1] (allowed: mapping, transmission, event_timer_ms, "
               "inhibit_100us); did you mean \"event_timer_ms\"?"},
       {18, 2,
        "unknown key \"colour\" in the top level (allowed: gateway, logging, bus, device, outputs, web, control, "
        "ascii_gateway, redundancy)"}});
  const LoadResult r = load(kFixtures / "bad_unknown_keys.toml");
  EXPECT_THAT(r.diagnostics()[1].message, HasSubstr("did you mean \"bitrate\"?"));
  EXPECT_THAT(r.diagnostics()[0].message, ::testing::Not(HasSubstr("did you mean")));
}

// CiA 301 §7.3.2 / J§1.2.2: node-IDs 1..127
TEST(ConfigErrors, NodeIdOutOfRange) {
  expect_diagnostics("bad_node_id_range.toml",
                     {{9, 11, "device \"zero\": node_id 0 is out of range (allowed: 1..127)"},
                      {15, 11, "device \"big\": node_id 128 is out of range (allowed: 1..127)"}});
}

// doc §Errors: names are unique (buses, devices across all buses)
TEST(ConfigErrors, DuplicateNames) {
  expect_diagnostics("bad_duplicate_names.toml",
                     {{6, 8, "duplicate bus name \"line1\" (first defined at 2:8)"},
                      {15, 8, "duplicate device name \"enc\" (first defined at 10:8)"}});
}

// CiA 301 §7.3.2: a node-ID is unique on its bus, not across buses
TEST(ConfigErrors, DuplicateNodeIdOnOneBus) {
  expect_diagnostics("bad_duplicate_node_id.toml",
                     {{25, 11, "device \"c\": node_id 5 is already used by device \"a\" on bus \"line1\" (13:11)"}});
}

// CiA 301 §7.5.2.23 (0x1018/4): serials are unique per vendor
TEST(ConfigErrors, DuplicateSerialOfOneVendor) {
  expect_diagnostics("bad_duplicate_serial.toml",
                     {{20, 10, "device \"c\": serial 42 is already used by device \"a\" (8:10)"}});
}

// doc §[[device]] bus
TEST(ConfigErrors, UnknownBus) {
  expect_diagnostics("bad_unknown_bus.toml",
                     {{7, 7, "device \"enc\": bus \"line9\" is not defined (defined buses: line1)"}});
}

// doc §[[device]] eds: the path is checked and named, relative to the file
TEST(ConfigErrors, MissingEds) {
  const std::string path = (kFixtures / "no-such-dir" / "missing.eds").string();
  expect_diagnostics("bad_missing_eds.toml", {{9, 7, "device \"enc\": eds file \"" + path + "\" does not exist"}});
}

// CiA 301 §7.1 bit-timing table (and F§7.4 0x3001): the allowed bit rates
TEST(ConfigErrors, BadBitrate) {
  expect_diagnostics("bad_bitrate.toml",
                     {{5, 11, "bus \"line1\": bitrate 300 is not allowed (allowed: 10, 20, 50, 100, 125, 250, 500, "
                              "800, 1000)"}});
  const LoadResult r = load(kFixtures / "bad_bitrate.toml");
  EXPECT_EQ(to_string(r.diagnostics().at(0)),
            (kFixtures / "bad_bitrate.toml").string() +
                ":5:11: bus \"line1\": bitrate 300 is not allowed (allowed: 10, 20, 50, 100, 125, 250, 500, 800, "
                "1000)");
}

// CiA 301 §7.3.2: pool node-IDs 1..127; doc §[[bus]] node_pool
TEST(ConfigErrors, BadNodePool) {
  expect_diagnostics("bad_node_pool.toml",
                     {{4, 13, "bus \"a\": node_pool \"60-10\" is not a valid node-ID range"},
                      {9, 14, "bus \"b\": node_pool entry 0 is out of range (allowed: 1..127)"},
                      {9, 17, "bus \"b\": node_pool \"10-128\" is not a valid node-ID range"},
                      {9, 27, "bus \"b\": node_pool \"x\" is not a valid node-ID range"},
                      {14, 13, "bus \"c\": node_pool is empty but commissioning is \"automatic\""}});
}

// TOML 1.0 syntax errors come with toml++'s position
TEST(ConfigErrors, TomlSyntaxError) {
  expect_diagnostics("bad_syntax.toml", {{3, 18, "TOML syntax error: "}});
}

// J§1.2.1, E§4.1, F§7.3: known models, their vendor, channels (J 1/2-channel
// variants), CAMs per channel (J§1.2.3: 4), filters (E§5.1/5.2 only)
TEST(ConfigErrors, ModelConstraints) {
  expect_diagnostics("bad_model.toml",
                     {{9, 9, "device \"a\": model \"RFC-480\" is not known (allowed: RFC-4800, RSA-3200"},
                      {16, 12, "device \"b\": channels is only allowed with a model of the rotary series"},
                      {17, 10, "device \"b\": vendor 0x0069666D does not match model \"MC1-2800\" (vendor 0x00000182)"},
                      {25, 16, "device \"c\": speed_filter is not supported by model \"RFC-4800\""},
                      {28, 9, "device \"c\": cam.index 5 is out of range (allowed: 1..4)"},
                      {35, 7, "device \"d\": give either model or eds, not both"},
                      {36, 19, "device \"d\": position_filter is not supported by model \"RM9\""}});
}

// CiA 301 0x1019 (sync counter), 0x1800 sub 2 (transmission types), §7.2.8
// (heartbeat or node guarding), 0x1A00 mapping entries; J§1.4.5 CAMs
TEST(ConfigErrors, DeviceSettings) {
  expect_diagnostics("bad_device_settings.toml",
                     {{4, 16, "bus \"line1\": sync_counter 1 is not allowed (allowed: 0 = no counter, or 2..240"},
                      {11, 13, "device \"a\": direction \"left\" is not allowed (allowed: cw, ccw)"},
                      {13, 1, "device \"a\": missing required key \"guarding.life_time_factor\" in [device.guarding]"},
                      {13, 1, "device \"a\": give either heartbeat_ms or [device.guarding], not both"},
                      {17, 24, "device \"a\": tpdo1.mapping entry \"angle\" is not allowed (allowed: position, speed"},
                      {17, 33, "device \"a\": tpdo1.mapping entry \"0x60040000\" is not a valid mapping entry"},
                      {18, 16, "device \"a\": tpdo1.transmission 250 is not allowed (allowed: 0..240, 254, 255"},
                      {21, 16, "device \"a\": tpdo2.transmission \"often\" is not allowed"},
                      {27, 9, "device \"a\": cam index 1 is defined twice (first at 24:9)"}});
}

// doc §Errors: required keys, interface names (Linux IFNAMSIZ), name syntax
TEST(ConfigErrors, MissingKeysAndBadNames) {
  expect_diagnostics("bad_missing_keys.toml",
                     {{1, 1, "bus #1: missing required key \"name\" in [[bus]]"},
                      {2, 13, "interface \"this-name-is-too-long\" is not a valid Linux interface name"},
                      {4, 1, "device \"a b\": missing required key \"bus\" in [[device]]"},
                      {4, 1, "device \"a b\": missing required key \"serial\" in [[device]]"},
                      {5, 8, "device \"a b\": name \"a b\" is not allowed"}});
}

// doc §Files: an unreadable file is a diagnostic, not an exception
TEST(ConfigErrors, MissingFile) {
  const LoadResult r = load(kFixtures / "does-not-exist.toml");
  ASSERT_FALSE(r.ok());
  ASSERT_EQ(r.diagnostics().size(), 1U);
  EXPECT_EQ(r.diagnostics()[0].line, 0U);
  EXPECT_THAT(r.diagnostics()[0].message, HasSubstr("cannot open the configuration file"));
  EXPECT_THAT(to_string(r.diagnostics()[0]), ::testing::StartsWith((kFixtures / "does-not-exist.toml").string() + ": "));
}

// doc §Files: a directory is not an empty configuration
TEST(ConfigErrors, DirectoryIsNotAFile) {
  const LoadResult r = load(kFixtures);
  ASSERT_FALSE(r.ok());
  ASSERT_EQ(r.diagnostics().size(), 1U);
  EXPECT_THAT(r.diagnostics()[0].message, HasSubstr("it is a directory"));
}

// Every fixture named bad_* fails and every good_* loads: a new fixture
// cannot be forgotten by the tests above.
TEST(ConfigErrors, EveryFixtureIsClassifiedByItsName) {
  int good = 0;
  int bad = 0;
  for (const auto& e : fs::directory_iterator(kFixtures)) {
    const std::string name = e.path().filename().string();
    const LoadResult r = load(e.path());
    if (name.rfind("good_", 0) == 0) {
      EXPECT_TRUE(r.ok()) << name;
      ++good;
    } else if (name.rfind("bad_", 0) == 0) {
      EXPECT_FALSE(r.ok()) << name;
      for (const auto& d : r.diagnostics()) {
        EXPECT_GT(d.line, 0U) << name << ": " << d.message;
        EXPECT_GT(d.column, 0U) << name << ": " << d.message;
      }
      ++bad;
    }
  }
  EXPECT_GE(good, 2);
  EXPECT_GE(bad, 10);
}

// ---- robustness ----------------------------------------------------------------

// doc §Errors: no input makes load throw or crash
TEST(ConfigRobustness, TruncationsOfTheExample) {
  const std::string text = read_text(kExample);
  ASSERT_FALSE(text.empty());
  const std::string base = kExample.parent_path().string();
  std::size_t failed = 0;
  for (std::size_t n = 0; n <= text.size(); ++n) {
    const LoadResult r = load_string(std::string_view(text).substr(0, n), "cut.toml", base);
    if (!r.ok()) {
      ++failed;
      ASSERT_FALSE(r.diagnostics().empty()) << "cut at " << n;
    }
  }
  EXPECT_GT(failed, 0U);
  EXPECT_TRUE(load_string(text, "whole.toml", base).ok());
}

TEST(ConfigRobustness, RandomBytesAndMutations) {
  std::mt19937 rng(12345);  // fixed seed: failures reproduce
  const std::string text = read_text(kExample);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int i = 0; i < 2000; ++i) {
    std::string junk(static_cast<std::size_t>(rng() % 512), '\0');
    for (auto& c : junk) c = static_cast<char>(byte(rng));
    const LoadResult r = load_string(junk, "junk.toml");
    ASSERT_TRUE(r.ok() || !r.diagnostics().empty());
  }
  // Mutations keep most of the structure, so they reach the schema checks.
  static constexpr char kTokens[] = "[]{}=\".,#\n 0123456789-x_";
  for (int i = 0; i < 3000; ++i) {
    std::string m = text;
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits; ++e) {
      const std::size_t pos = rng() % m.size();
      switch (rng() % 3) {
        case 0: m[pos] = kTokens[rng() % (sizeof kTokens - 1)]; break;
        case 1: m.erase(pos, 1 + rng() % 8); break;
        default: m.insert(pos, 1, static_cast<char>(byte(rng))); break;
      }
      if (m.empty()) m = "x";
    }
    const LoadResult r = load_string(m, "mutant.toml", kExample.parent_path());
    ASSERT_TRUE(r.ok() || !r.diagnostics().empty());
  }
}

// Deep nesting and huge numbers are rejected, not recursed into or wrapped.
TEST(ConfigRobustness, PathologicalInputs) {
  const std::string deep = "x = " + std::string(100000, '[') + std::string(100000, ']');
  EXPECT_FALSE(load_string(deep, "deep.toml").ok());
  EXPECT_FALSE(load_string("[[bus]]\nname = \"a\"\ninterface = \"can0\"\nsdo_retries = 9223372036854775807\n", "big.toml").ok());
  EXPECT_FALSE(load_string("[[bus]]\nname = \"a\"\ninterface = \"can0\"\nbitrate = 99999999999999999999\n", "big.toml").ok());
  EXPECT_FALSE(load_string(std::string("a = \"\0\"", 7), "nul.toml").ok());
  EXPECT_FALSE(load_string("bus = 5\ndevice = [1, 2]\noutputs = 3\n", "shapes.toml").ok());
}

// J§1.2.1, E§4.1 (incl. E§13 V03 codes), F§7.3: the model table
TEST(KnownModels, MatchTheManuals) {
  ASSERT_EQ(known_models().size(), 12U);
  const KnownModel* rfc = find_model("RFC-4800");
  ASSERT_NE(rfc, nullptr);
  EXPECT_EQ(rfc->vendor, 0x182U);
  EXPECT_EQ(rfc->products.size(), 1U);
  EXPECT_EQ(rfc->products[0], 0x0BE0U);
  EXPECT_EQ(rfc->max_channels, 2);
  const KnownModel* mc1 = find_model("MC1-2800");
  ASSERT_NE(mc1, nullptr);
  EXPECT_EQ(mc1->family, families::FamilyId::novotechnik_multiturn);
  EXPECT_NE(std::find(mc1->products.begin(), mc1->products.end(), 0x0BB8U), mc1->products.end());
  EXPECT_NE(std::find(mc1->products.begin(), mc1->products.end(), 0x0BB9U), mc1->products.end());
  const KnownModel* rm9 = find_model("RM9");
  ASSERT_NE(rm9, nullptr);
  EXPECT_EQ(rm9->vendor, 0x0069666DU);
  EXPECT_EQ(rm9->cams_per_channel, 8);
  EXPECT_EQ(find_model("rm9"), nullptr);
  // F§7.3 0x1008: the device calls itself "RM9000"; the config accepts that name too.
  const KnownModel* rm9000 = find_model("RM9000");
  ASSERT_NE(rm9000, nullptr);
  EXPECT_EQ(rm9000->family, families::FamilyId::ifm_rm);
}

}  // namespace
}  // namespace cobridge::config
