// PluginHost and the plugin C ABI, with real dlopen: the dummy plugins in
// test_plugins/ (C, built for the current, an older and a newer ABI, and
// broken in various ways) and the JSON tap plugin. Each test plugin exports a
// test_plugin_record; the test opens the same library itself and reads what
// the plugin saw.
#include "pipeline/plugin_host.hpp"
#include "pipeline/sample.hpp"
#include "unit/pipeline/test_plugins/test_plugin_record.h"

#include <dlfcn.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <array>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace fs = std::filesystem;
using cobridge::Errc;
using cobridge::Error;
using namespace cobridge::pipeline;

namespace {

const fs::path kTestPluginDir = COBRIDGE_TEST_PLUGIN_DIR;
const fs::path kJsonTapDir = COBRIDGE_JSONTAP_DIR;

// Holds its own reference to a test plugin library so that the record
// outlives the host's dlclose, and zeroes it before the host loads it.
class Record {
 public:
  explicit Record(const std::string& type) {
    const fs::path path = kTestPluginDir / ("libcobridge_" + type + ".so");
    handle_ = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle_ == nullptr) {
      ADD_FAILURE() << "cannot open " << path << ": " << dlerror();
      return;
    }
    record_ = static_cast<test_record*>(dlsym(handle_, TEST_PLUGIN_RECORD));
    if (record_ == nullptr) {
      ADD_FAILURE() << path << " exports no " << TEST_PLUGIN_RECORD;
      return;
    }
    std::memset(record_, 0, sizeof *record_);
  }
  ~Record() {
    if (handle_ != nullptr) dlclose(handle_);
  }
  Record(const Record&) = delete;
  Record& operator=(const Record&) = delete;
  const test_record* operator->() const { return record_ != nullptr ? record_ : &empty_; }

 private:
  void* handle_ = nullptr;
  test_record* record_ = nullptr;
  test_record empty_{};
};

struct LogLine {
  LogLevel level;
  std::string instance;
  std::string message;
};

// A thread-safe log sink that keeps every line.
class LogCapture {
 public:
  PluginHost::LogSink sink() {
    return [this](LogLevel level, std::string_view instance, std::string_view message) {
      std::lock_guard lock(mutex_);
      lines_.push_back({level, std::string(instance), std::string(message)});
    };
  }
  std::vector<LogLine> lines() const {
    std::lock_guard lock(mutex_);
    return lines_;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<LogLine> lines_;
};

PluginHost::LogSink quiet() {
  return [](LogLevel, std::string_view, std::string_view) {};
}

// A scratch directory per test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            ("cobridge_plugin_test_" + std::to_string(getpid()) + "_" + info->test_suite_name() + "_" + info->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

PluginSpec spec(std::string instance, std::string type, std::string config = {}) {
  return PluginSpec{std::move(instance), std::move(type), {}, std::move(config)};
}

Sample tpdo(std::uint32_t sequence, std::int64_t position) {
  Sample s = make_sample(SampleKind::kTpdo, 2, 0, 5, 1'000'000'000ull + sequence);
  s.sequence = sequence;
  set_position(s, position);
  return s;
}

std::string read_file(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

cobridge_device_info device(const char* name) {
  cobridge_device_info info{};
  info.struct_size = sizeof info;
  info.device_index = 2;
  info.bus_index = 0;
  info.node_id = 5;
  info.change = COBRIDGE_DEVICE_ADDED;
  info.vendor_id = 0x0000'0065;
  info.product_code = 0x0000'4711;
  info.revision = 0x0001'0002;
  info.serial = 123456;
  info.name = name;
  info.bus_name = "can0";
  info.model = "RSC-2800";
  info.family = "rotary";
  info.position_unit = "deg";
  return info;
}

}  // namespace

// Concept: the ABI-1 round trip — create gets the host API and the config
// text, start/on_samples/on_device/stop/destroy are called, and the plugin
// sees exactly the sample values the host delivered.
TEST(PluginHostAbi, V1PluginLoadsAndReceivesSamples) {
  Record rec("test_v1");
  LogCapture log;
  PluginHost host({kTestPluginDir, "gw-7", log.sink()});

  const Error error = host.load(spec("tap", "test_v1", "answer = 42"));
  ASSERT_FALSE(error) << error.to_string();
  EXPECT_EQ(rec->created, 1);
  EXPECT_EQ(rec->host_abi_version, COBRIDGE_PLUGIN_ABI_VERSION);
  EXPECT_STREQ(rec->gateway_id, "gw-7");
  EXPECT_STREQ(rec->config, "answer = 42");
  EXPECT_EQ(rec->started, 0) << "create must not start";

  EXPECT_TRUE(host.start_all().empty());
  EXPECT_EQ(rec->started, 1);
  EXPECT_EQ(host.started_count(), 1u);

  const std::array<Sample, 3> batch = {tpdo(10, 100), tpdo(11, -5), tpdo(12, 7)};
  host.deliver(batch);
  EXPECT_EQ(rec->on_samples_calls, 1) << "one batch, one call";
  EXPECT_EQ(rec->samples_seen, 3u);
  EXPECT_EQ(rec->position_sum, 102);
  EXPECT_EQ(rec->last_sample.sequence, 12u);
  EXPECT_EQ(rec->last_sample.node_id, 5);
  EXPECT_EQ(rec->last_sample.device_index, 2);
  EXPECT_EQ(rec->last_sample.rx_timestamp_ns, 1'000'000'012ull);

  const auto info = device("spindle");
  host.announce(info);
  EXPECT_EQ(rec->on_device_calls, 1);
  EXPECT_STREQ(rec->last_device_name, "spindle");

  // ABI 4: a role change reaches the plugin with its cause.
  cobridge_role_info role{};
  role.struct_size = sizeof role;
  role.role = COBRIDGE_ROLE_STANDBY;
  role.master_node = 120;
  role.bus_name = "line1";
  role.cause = "an active master answered";
  host.announce_role(role);
  EXPECT_EQ(rec->on_role_calls, 1);
  EXPECT_EQ(rec->last_role, COBRIDGE_ROLE_STANDBY);
  EXPECT_EQ(rec->last_role_master, 120);
  EXPECT_STREQ(rec->last_role_cause, "an active master answered");
  EXPECT_EQ(rec->host_redundancy_node, 0u) << "no [redundancy]: the plugin is told it runs alone";

  // ABI 5: a bus's health reaches the plugin (plugin.h cobridge_bus_info).
  cobridge_bus_info bus{};
  bus.struct_size = sizeof bus;
  bus.state = COBRIDGE_CONTROLLER_BUS_OFF;
  bus.tx_errors = 256;
  bus.restarts = 3;
  bus.bus_name = "line1";
  host.announce_bus(bus);
  EXPECT_EQ(rec->on_bus_calls, 1);
  EXPECT_EQ(rec->last_bus_state, COBRIDGE_CONTROLLER_BUS_OFF);
  EXPECT_EQ(rec->last_bus_tx_errors, 256);
  EXPECT_EQ(rec->last_bus_restarts, 3u);
  EXPECT_STREQ(rec->last_bus_name, "line1");

  host.stop_all();
  EXPECT_EQ(rec->stopped, 1);
  host.deliver(batch);
  EXPECT_EQ(rec->on_samples_calls, 1) << "a stopped plugin receives nothing";

  host.unload_all();
  EXPECT_EQ(rec->destroyed, 1);
  EXPECT_EQ(host.loaded_count(), 0u);

  // The plugin's host->log calls reach the sink tagged with the instance.
  bool saw_start = false;
  for (const auto& l : log.lines()) saw_start |= (l.instance == "tap" && l.message == "start");
  EXPECT_TRUE(saw_start);
}

// Concept: ABI 3 stats — the host reads an output's own figures from a
// control-plane thread only while it runs, keeps the instance/type, and
// leaves out a figure whose name could not be a Prometheus metric name.
TEST(PluginHostAbi, StatsAreReadWhileRunningAndBadNamesLeftOut) {
  Record rec("test_v1");
  LogCapture log;
  PluginHost host({kTestPluginDir, "gw", log.sink()});
  ASSERT_FALSE(host.load(spec("tap", "test_v1")));
  auto before = host.stats();
  ASSERT_EQ(before.size(), 1u);
  EXPECT_FALSE(before[0].running);
  EXPECT_TRUE(before[0].figures.empty()) << "not started: no figures";
  EXPECT_EQ(rec->stats_calls, 0);

  ASSERT_TRUE(host.start_all().empty());
  const std::array<Sample, 2> batch = {tpdo(1, 1), tpdo(2, 2)};
  host.deliver(batch);
  std::vector<OutputStats> seen;
  std::thread reader([&] { seen = host.stats(); });  // as the web thread does
  reader.join();
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].instance, "tap");
  EXPECT_EQ(seen[0].type, "test_v1");
  EXPECT_TRUE(seen[0].running);
  ASSERT_EQ(seen[0].figures.size(), 2u) << "Bad-Name must be left out";
  EXPECT_EQ(seen[0].figures[0].name, "test_samples_seen");
  EXPECT_TRUE(seen[0].figures[0].counter);
  EXPECT_EQ(seen[0].figures[0].value, 2u);
  EXPECT_EQ(seen[0].figures[1].name, "test_level");
  EXPECT_FALSE(seen[0].figures[1].counter);
  EXPECT_EQ(seen[0].figures[1].value, 7u);

  host.stop_all();
  const int calls = rec->stats_calls;
  EXPECT_TRUE(host.stats()[0].figures.empty());
  EXPECT_EQ(rec->stats_calls, calls) << "a stopped plugin's stats must not be called";
}

// Concept: backward compatibility (plugin.h "Versioning") — a plugin built
// for ABI 4 has no on_bus: the host reads its struct_size and never calls
// the trap that sits where an ABI 5 table has on_bus.
TEST(PluginHostAbi, Abi4PluginIsNeverToldBusHealth) {
  Record rec("test_abi4");
  LogCapture log;
  PluginHost host({kTestPluginDir, "gw", log.sink()});
  const Error error = host.load(spec("four", "test_abi4"));
  ASSERT_FALSE(error) << error.to_string();
  EXPECT_TRUE(host.start_all().empty());
  cobridge_bus_info bus{};
  bus.struct_size = sizeof bus;
  bus.bus_name = "line1";
  host.announce_bus(bus);
  host.unload_all();
  EXPECT_EQ(rec->started, 1);
  EXPECT_EQ(rec->trap_calls, 0) << "the host called on_bus past the plugin's struct_size";
  EXPECT_EQ(rec->destroyed, 1);
}

// Concept: backward compatibility — a plugin built for ABI 0, whose ops table
// ends at on_samples, still loads and runs, and the host never calls an op
// beyond its struct_size (the trap behind the table stays untouched).
TEST(PluginHostAbi, OlderAbiPluginLoadsAndMissingOpsAreNeverCalled) {
  Record rec("test_old_abi");
  LogCapture log;
  PluginHost host({kTestPluginDir, "gw", log.sink()});

  const Error error = host.load(spec("old", "test_old_abi"));
  ASSERT_FALSE(error) << error.to_string();
  EXPECT_TRUE(host.start_all().empty());
  const std::array<Sample, 2> batch = {tpdo(1, 1), tpdo(2, 2)};
  host.deliver(batch);
  host.announce(device("spindle"));
  host.unload_all();

  EXPECT_EQ(rec->started, 1);
  EXPECT_EQ(rec->samples_seen, 2u);
  EXPECT_EQ(rec->last_sample.sequence, 2u);
  EXPECT_EQ(rec->trap_calls, 0) << "the host called on_device past the plugin's struct_size";
  EXPECT_EQ(rec->stopped, 1);
  EXPECT_EQ(rec->destroyed, 1);
}

// Concept: forward refusal — a plugin built for a newer ABI than the host's is
// refused with a message naming the file and both versions, and the instance
// it created is destroyed (unwinding in reverse) without any other op.
TEST(PluginHostAbi, NewerAbiPluginIsRefusedWithClearMessage) {
  Record rec("test_new_abi");
  LogCapture log;
  PluginHost host({kTestPluginDir, "gw", log.sink()});

  const Error error = host.load(spec("future", "test_new_abi"));
  EXPECT_EQ(error.code, PluginErrc::kAbiTooNew);
  EXPECT_EQ(error.kind, Errc::kUnsupported);
  EXPECT_EQ(error.where, "plugin 'future'") << "no PluginSpec::where: the instance names the place";
  EXPECT_NE(error.message.find("libcobridge_test_new_abi.so"), std::string::npos) << error.message;
  const std::string newer = "ABI version " + std::to_string(COBRIDGE_PLUGIN_ABI_VERSION + 1) + " is newer than the host's " +
                            std::to_string(COBRIDGE_PLUGIN_ABI_VERSION);
  EXPECT_NE(error.message.find(newer), std::string::npos) << error.message;
  EXPECT_EQ(host.loaded_count(), 0u);
  EXPECT_EQ(rec->created, 1);
  EXPECT_EQ(rec->destroyed, 1);
  EXPECT_EQ(rec->started, 0);
  EXPECT_EQ(rec->trap_calls, 0);

  // Reported once through the log, at error level.
  const auto lines = log.lines();
  ASSERT_FALSE(lines.empty());
  EXPECT_EQ(lines.back().level, LogLevel::kError);
  EXPECT_EQ(lines.back().message, error.message);
}

// Concept: load errors are reported with code, file and reason.
TEST(PluginHostLoadErrors, MissingFileIsReported) {
  PluginHost host({kTestPluginDir, "gw", quiet()});
  Error error;
  EXPECT_EQ((error = host.load(spec("x", "does_not_exist"))).code, PluginErrc::kFileNotFound);
  EXPECT_EQ(error.kind, Errc::kNotFound);
  EXPECT_EQ(error.where, "plugin 'x'");
  EXPECT_NE(error.message.find("libcobridge_does_not_exist.so: file not found"), std::string::npos)
      << error.message;
}

TEST(PluginHostLoadErrors, RandomBytesNamedSoAreNotLoadable) {
  TempDir dir;
  const fs::path garbage = dir.path() / "libcobridge_garbage.so";
  {
    std::ofstream out(garbage, std::ios::binary);
    std::uint32_t x = 0x12345678u;
    for (int i = 0; i < 4096; ++i) {
      x = x * 1664525u + 1013904223u;
      out.put(static_cast<char>(x >> 24));
    }
  }
  PluginHost host({dir.path(), "gw", quiet()});
  Error error;
  EXPECT_EQ((error = host.load(spec("g", "garbage"))).code, PluginErrc::kNotLoadable);
  EXPECT_NE(error.message.find(garbage.string() + ": not a loadable shared object"), std::string::npos)
      << error.message;
}

// A plugin runs with the service's rights, so a file or
// directory someone else could have written is refused before dlopen (the
// reason is the trust check's, not "not a loadable shared object").
TEST(PluginHostLoadErrors, AFileOthersCouldWriteIsRefusedBeforeItIsOpened) {
  TempDir dir;
  const fs::path file = dir.path() / "libcobridge_shared.so";
  std::ofstream(file) << "not even ELF";
  PluginHost host({dir.path(), "gw", quiet()});
  fs::permissions(file, fs::perms::group_write | fs::perms::others_write, fs::perm_options::add);
  Error error = host.load(spec("s", "shared"));
  EXPECT_EQ(error.code, PluginErrc::kNotTrusted);
  EXPECT_EQ(error.kind, Errc::kPermissionDenied);
  EXPECT_NE(error.message.find("refused: plugin file " + file.string() + " is writable by group or others (mode 06"),
            std::string::npos)
      << error.message;
  fs::permissions(file, fs::perms::group_write | fs::perms::others_write, fs::perm_options::remove);
  fs::permissions(dir.path(), fs::perms::others_write, fs::perm_options::add);
  error = host.load(spec("s", "shared"));
  EXPECT_NE(error.message.find("plugin directory " + dir.path().string() + " is writable by group or others"),
            std::string::npos)
      << error.message;
  fs::permissions(dir.path(), fs::perms::others_write, fs::perm_options::remove);
  if (::geteuid() == 0) {  // only root can give the file away
    ASSERT_EQ(::chown(file.c_str(), 12345, 12345), 0);
    error = host.load(spec("s", "shared"));
    EXPECT_NE(error.message.find("is owned by uid 12345, neither root nor the daemon's user"), std::string::npos)
        << error.message;
  }
}

TEST(PluginHostLoadErrors, SharedObjectWithoutEntryPointIsReported) {
  PluginHost host({kTestPluginDir, "gw", quiet()});
  Error error;
  EXPECT_EQ((error = host.load(spec("n", "test_no_entry"))).code, PluginErrc::kNoEntryPoint);
  EXPECT_NE(error.message.find("libcobridge_test_no_entry.so: no entry point cobridge_plugin_create"),
            std::string::npos)
      << error.message;
}

TEST(PluginHostLoadErrors, CreateFailureCarriesThePluginsMessage) {
  Record rec("test_faulty");
  PluginHost host({kTestPluginDir, "gw", quiet()});
  Error error;
  EXPECT_EQ((error = host.load(spec("f", "test_faulty", "create_fails"))).code, PluginErrc::kCreateFailed);
  EXPECT_NE(error.message.find("libcobridge_test_faulty.so: create failed: serial port /dev/ttyX4 does not exist"),
            std::string::npos)
      << error.message;
  EXPECT_EQ(rec->destroyed, 0) << "a failed create has nothing to destroy";
}

TEST(PluginHostLoadErrors, NullOpsTableIsRefused) {
  PluginHost host({kTestPluginDir, "gw", quiet()});
  Error error;
  EXPECT_EQ((error = host.load(spec("f", "test_faulty", "null_ops"))).code, PluginErrc::kNullOps);
  EXPECT_NE(error.message.find("returned no ops table"), std::string::npos) << error.message;
}

// Concept: one error shape — a plugin failure is an Error whose
// where is the place the caller's configuration names the instance, whose
// message names the file and the reason, and whose code is the PluginErrc.
TEST(PluginHostLoadErrors, ErrorCarriesTheCallersWhere) {
  PluginHost host({kTestPluginDir, "gw", quiet()});
  PluginSpec s = spec("x", "does_not_exist");
  s.where = "cobridge.toml:40:1: [outputs.x]";
  const Error error = host.load(s);
  EXPECT_EQ(error.code, PluginErrc::kFileNotFound);
  EXPECT_EQ(error.kind, Errc::kNotFound);
  EXPECT_EQ(error.where, s.where);
  EXPECT_EQ(error.to_string(), "cobridge.toml:40:1: [outputs.x]: " + host.resolve(s).string() + ": file not found");
}

// Concept: every PluginErrc maps to the kind a caller acts on (docs/operations.md).
TEST(PluginHostLoadErrors, EveryCodeHasAKind) {
  EXPECT_EQ(plugin_error_kind(PluginErrc::kFileNotFound), Errc::kNotFound);
  EXPECT_EQ(plugin_error_kind(PluginErrc::kNotTrusted), Errc::kPermissionDenied);
  EXPECT_EQ(plugin_error_kind(PluginErrc::kNotLoadable), Errc::kInvalidArgument);
  EXPECT_EQ(plugin_error_kind(PluginErrc::kNoEntryPoint), Errc::kInvalidArgument);
  EXPECT_EQ(plugin_error_kind(PluginErrc::kCreateFailed), Errc::kInvalidArgument);
  EXPECT_EQ(plugin_error_kind(PluginErrc::kNullOps), Errc::kInvalidArgument);
  EXPECT_EQ(plugin_error_kind(PluginErrc::kAbiTooNew), Errc::kUnsupported);
  EXPECT_EQ(plugin_error_kind(PluginErrc::kBadOps), Errc::kInvalidArgument);
  EXPECT_EQ(plugin_error_kind(PluginErrc::kStartFailed), Errc::kFailed);
}

// Concept: a table too small for the mandatory ops, or with a NULL mandatory
// op, is refused and the instance destroyed.
TEST(PluginHostLoadErrors, MalformedOpsTableIsRefusedAndDestroyed) {
  Record rec("test_faulty");
  PluginHost host({kTestPluginDir, "gw", quiet()});
  Error error;
  EXPECT_EQ((error = host.load(spec("f1", "test_faulty", "small_table"))).code, PluginErrc::kBadOps);
  EXPECT_NE(error.message.find("struct_size 16 is below the minimum 48"), std::string::npos) << error.message;
  EXPECT_EQ((error = host.load(spec("f2", "test_faulty", "missing_op"))).code, PluginErrc::kBadOps);
  EXPECT_NE(error.message.find("lacks a mandatory op"), std::string::npos) << error.message;
  EXPECT_EQ(rec->created, 2);
  // small_table's struct_size does not even cover destroy: nothing may be
  // called on it. missing_op is destroyed.
  EXPECT_EQ(rec->destroyed, 1);
  EXPECT_EQ(rec->started, 0);
  EXPECT_EQ(host.loaded_count(), 0u);
}

// Concept: isolation — every kind of broken plugin in one configuration is
// reported, and the good plugins around them load, start and keep receiving.
TEST(PluginHostIsolation, BrokenPluginsDoNotTakeOthersDown) {
  // In the plugin directory: plugins load from there only.
  const fs::path garbage = kTestPluginDir / ("libcobridge_garbage_" + std::to_string(::getpid()) + ".so");
  std::ofstream(garbage) << "this is not an ELF file";
  struct Remove {
    fs::path p;
    ~Remove() { fs::remove(p); }
  } remove_garbage{garbage};

  Record v1("test_v1");
  Record old("test_old_abi");
  PluginHost host({kTestPluginDir, "gw", quiet()});
  const std::vector<PluginSpec> specs = {
      spec("good", "test_v1"),
      spec("missing", "does_not_exist"),
      PluginSpec{"garbage", "garbage", garbage.filename(), {}},
      spec("noentry", "test_no_entry"),
      spec("fails", "test_faulty", "create_fails"),
      spec("future", "test_new_abi"),
      spec("old", "test_old_abi"),
  };
  const auto errors = host.load_all(specs);
  ASSERT_EQ(errors.size(), 5u);
  EXPECT_EQ(errors[0].code, PluginErrc::kFileNotFound);
  EXPECT_EQ(errors[1].code, PluginErrc::kNotLoadable);
  EXPECT_NE(errors[1].message.find(garbage.string()), std::string::npos) << errors[1].message;
  EXPECT_EQ(errors[2].code, PluginErrc::kNoEntryPoint);
  EXPECT_EQ(errors[3].code, PluginErrc::kCreateFailed);
  EXPECT_EQ(errors[4].code, PluginErrc::kAbiTooNew);
  for (std::size_t i = 0; i < errors.size(); ++i) {
    const auto& e = errors[i];
    const PluginSpec& s = specs[i + 1];  // the failures are specs 1..5, in order
    EXPECT_NE(e.message.find(host.resolve(s).string()), std::string::npos) << "message must name the file: " << e.message;
    EXPECT_EQ(e.where, "plugin '" + s.instance + "'");
  }
  EXPECT_EQ(host.instances(), (std::vector<std::string>{"good", "old"}));

  EXPECT_TRUE(host.start_all().empty());
  const std::array<Sample, 1> batch = {tpdo(1, 42)};
  host.deliver(batch);
  EXPECT_EQ(v1->samples_seen, 1u);
  EXPECT_EQ(v1->position_sum, 42);
  EXPECT_EQ(old->samples_seen, 1u);
}

// Concept: a plugin whose start fails is unloaded alone; the others run.
TEST(PluginHostIsolation, StartFailureUnloadsOnlyThatPlugin) {
  Record v1("test_v1");
  Record faulty("test_faulty");
  PluginHost host({kTestPluginDir, "gw", quiet()});
  ASSERT_FALSE(host.load(spec("bad", "test_faulty", "start_fails")));
  ASSERT_FALSE(host.load(spec("good", "test_v1")));

  const auto errors = host.start_all();
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].code, PluginErrc::kStartFailed);
  EXPECT_EQ(errors[0].kind, Errc::kFailed);
  EXPECT_EQ(errors[0].where, "plugin 'bad'");
  EXPECT_NE(errors[0].message.find("libcobridge_test_faulty.so: start failed (code 7)"), std::string::npos)
      << errors[0].message;
  EXPECT_EQ(faulty->stopped, 0) << "stop is only for a started plugin";
  EXPECT_EQ(faulty->destroyed, 1);
  EXPECT_EQ(host.instances(), (std::vector<std::string>{"good"}));

  const std::array<Sample, 1> batch = {tpdo(1, 9)};
  host.deliver(batch);
  EXPECT_EQ(v1->samples_seen, 1u);
  EXPECT_EQ(faulty->on_samples_calls, 0);
}

// Concept: shutdown order — plugins stop in reverse load order (a later
// plugin may depend on an earlier one), and unload destroys each instance.
TEST(PluginHostLifecycle, StopAllRunsInReverseLoadOrder) {
  Record rec("test_v1");
  LogCapture log;
  PluginHost host({kTestPluginDir, "gw", log.sink()});
  ASSERT_FALSE(host.load(spec("first", "test_v1")));
  ASSERT_FALSE(host.load(spec("second", "test_v1")));
  ASSERT_FALSE(host.load(spec("third", "test_v1")));
  EXPECT_TRUE(host.start_all().empty());
  host.stop_all();

  std::vector<std::string> stopped;
  for (const auto& l : log.lines()) {
    if (l.message == "stop") stopped.push_back(l.instance);
  }
  EXPECT_EQ(stopped, (std::vector<std::string>{"third", "second", "first"}));
  EXPECT_EQ(host.started_count(), 0u);
  EXPECT_EQ(host.loaded_count(), 3u) << "stopped plugins stay loaded until unload";
  host.unload_all();
  EXPECT_EQ(rec->destroyed, 3);
}

// Concept: file resolution — "libcobridge_<type>.so" in the plugin
// directory by default, an explicit relative file in the directory, an
// absolute file as is.
TEST(PluginHostLifecycle, ResolvesPluginFiles) {
  PluginHost host({"/opt/plugins", "gw", quiet()});
  EXPECT_EQ(host.resolve(spec("a", "dds")), fs::path("/opt/plugins/libcobridge_dds.so"));
  EXPECT_EQ(host.resolve(PluginSpec{"b", "dds", "custom.so", {}}), fs::path("/opt/plugins/custom.so"));
  // Never outside the plugin directory (the loader refuses paths too).
  EXPECT_EQ(host.resolve(PluginSpec{"c", "dds", "/usr/lib/x.so", {}}), fs::path("/opt/plugins/x.so"));
}

// ---------------------------------------------------------------------------
// JSON tap

namespace {

std::string tap_config(const fs::path& out, bool flush) {
  return "path = \"" + out.string() + "\"\nflush = " + (flush ? "true" : "false") + "\n";
}

}  // namespace

// Concept: JSON Lines output — one object per sample, header fields always,
// optional fields only when flagged valid, named as in cobridge_sample.
// The EMCY sample carries code 0x6000 (J§1.8.1: TPDO only partially sent).
TEST(JsonTap, WritesOneLinePerSampleWithOnlyValidFields) {
  TempDir dir;
  const fs::path out = dir.path() / "tap.jsonl";
  PluginHost host({kJsonTapDir, "gw", quiet()});
  const Error error = host.load(spec("tap", "jsontap", tap_config(out, false)));
  ASSERT_FALSE(error) << error.to_string();
  ASSERT_TRUE(host.start_all().empty());

  Sample pos = tpdo(7, 12345);
  pos.publish_timestamp_ns = 2'000'000'000ull;
  pos.sync_counter = 3;
  set_position_eng(pos, 90.5);
  const std::array<std::uint8_t, 4> payload = {0x39, 0x30, 0x00, 0x00};
  set_raw(pos, 0x185, payload);

  Sample emcy = make_sample(SampleKind::kEmcy, 2, 0, 5, 5);
  const std::array<std::uint8_t, 8> emcy_frame = {0x00, 0x60, 0x11, 0xAA, 0xBB, 0xCC, 0xDD, 0xEE};
  set_emcy(emcy, emcy_frame);

  Sample status = make_sample(SampleKind::kStatus, 2, 0, 5, 6);
  set_status(status, false, true);

  const std::array<Sample, 3> batch = {pos, emcy, status};
  host.deliver(batch);
  host.announce(device("axis \"A\"\t1"));
  host.stop_all();

  const auto lines = split_lines(read_file(out));
  ASSERT_EQ(lines.size(), 4u) << read_file(out);

  EXPECT_EQ(lines[0],
            "{\"type\":\"sample\",\"kind\":\"tpdo\",\"rx_timestamp_ns\":1000000007,"
            "\"publish_timestamp_ns\":2000000000,\"sequence\":7,\"device_index\":2,\"bus_index\":0,"
            "\"node_id\":5,\"sync_counter\":3,\"cob_id\":389,\"position\":12345,\"position_eng\":90.5,"
            "\"raw_len\":4,\"raw\":\"39300000\"}");
  EXPECT_EQ(lines[0].find("speed"), std::string::npos) << "speed was not flagged valid";

  EXPECT_NE(lines[1].find("\"kind\":\"emcy\""), std::string::npos) << lines[1];
  EXPECT_NE(lines[1].find("\"emcy_code\":24576,\"emcy_register\":17,\"emcy_data\":\"aabbccddee\""),
            std::string::npos)
      << lines[1];
  EXPECT_EQ(lines[1].find("position"), std::string::npos) << lines[1];

  EXPECT_NE(lines[2].find("\"kind\":\"status\""), std::string::npos) << lines[2];
  EXPECT_NE(lines[2].find("\"online\":false,\"stale\":true}"), std::string::npos) << lines[2];

  EXPECT_EQ(lines[3],
            "{\"type\":\"device\",\"change\":\"added\",\"device_index\":2,\"bus_index\":0,\"node_id\":5,"
            "\"vendor_id\":101,\"product_code\":18193,\"revision\":65538,\"serial\":123456,"
            "\"name\":\"axis \\\"A\\\"\\u00091\",\"bus_name\":\"can0\",\"model\":\"RSC-2800\","
            "\"family\":\"rotary\",\"position_unit\":\"deg\"}");
}

// Concept: flush = true makes each batch visible in the file right away.
TEST(JsonTap, FlushMakesEachBatchVisibleBeforeStop) {
  TempDir dir;
  const fs::path out = dir.path() / "tap.jsonl";
  PluginHost host({kJsonTapDir, "gw", quiet()});
  ASSERT_FALSE(host.load(spec("tap", "jsontap", tap_config(out, true))));
  ASSERT_TRUE(host.start_all().empty());
  const std::array<Sample, 2> batch = {tpdo(1, 10), tpdo(2, 20)};
  host.deliver(batch);
  const auto lines = split_lines(read_file(out));
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_NE(lines[1].find("\"sequence\":2,"), std::string::npos) << lines[1];
  EXPECT_NE(lines[1].find("\"position\":20}"), std::string::npos) << lines[1];
}

// Concept: configuration errors surface as a create failure with the
// plugin's own message, naming the offending key.
TEST(JsonTap, RejectsBadConfiguration) {
  PluginHost host({kJsonTapDir, "gw", quiet()});
  Error error;
  EXPECT_EQ((error = host.load(spec("tap", "jsontap", "pth = \"/tmp/x\"\n"))).code, PluginErrc::kCreateFailed);
  EXPECT_NE(error.message.find("unknown key 'pth'"), std::string::npos) << error.message;
  EXPECT_EQ((error = host.load(spec("tap", "jsontap", "flush = \"yes\"\n"))).code, PluginErrc::kCreateFailed);
  EXPECT_NE(error.message.find("'flush' must be a boolean"), std::string::npos) << error.message;
  EXPECT_EQ((error = host.load(spec("tap", "jsontap", "path = [\n"))).code, PluginErrc::kCreateFailed);
  EXPECT_NE(error.message.find("config: "), std::string::npos) << error.message;
}

// Concept: an output that cannot be opened fails start, logged by the plugin.
TEST(JsonTap, UnwritablePathFailsStart) {
  LogCapture log;
  PluginHost host({kJsonTapDir, "gw", log.sink()});
  ASSERT_FALSE(host.load(spec("tap", "jsontap", "path = \"/nonexistent-dir/x.jsonl\"\n")));
  const auto errors = host.start_all();
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].code, PluginErrc::kStartFailed);
  bool logged = false;
  for (const auto& l : log.lines()) logged |= l.message.find("cannot open /nonexistent-dir/x.jsonl") == 0;
  EXPECT_TRUE(logged);
}
