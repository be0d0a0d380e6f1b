// BusManager against cobridge-sim on vcan0 (inside UML): devices found,
// commissioned, configured and started; a power-cycled device back within
// 1 s of its boot-up; a silenced device offline within its heartbeat consumer
// time and online again when it speaks.
//
// The simulator is the build tree's: this binary lives in <build>/tests/, the
// simulator the build made (COBRIDGE_SIM_PATH, the cobridge-sim target).
#include "bus/bus_manager.hpp"

#include "can/socketcan_channel.hpp"
#include "canopen/cob_id.hpp"
#include "config/load.hpp"
#include "device/device_catalog.hpp"
#include "bus/state_store.hpp"
#include "bus/supervisor.hpp"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace cobridge::bus {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

constexpr std::uint32_t kRotarySerial = 101;     // RFC-4800 at its factory node-ID 127 (J§1.2.2)
constexpr std::uint32_t kMultiturnSerial = 102;  // MC1-2800, already at its node-ID
constexpr std::uint32_t kIfmSerial = 103;        // RM8000, already at its node-ID
constexpr std::uint16_t kHeartbeatMs = 100;

fs::path repo_root() { return fs::path(__FILE__).parent_path().parent_path().parent_path().parent_path(); }

fs::path simulator_path() { return COBRIDGE_SIM_PATH; }

// cobridge-sim as a child process; "ready" on its stdout means its devices
// are powered on.
class SimProcess {
 public:
  bool start(const std::vector<std::string>& args, std::string& error) {
    const fs::path exe = simulator_path();
    if (!fs::exists(exe)) {
      error = "simulator not found at " + exe.string() + " (build the cobridge-sim target)";
      return false;
    }
    int out[2];
    if (::pipe2(out, O_CLOEXEC) != 0) {
      error = "pipe failed";
      return false;
    }
    pid_ = ::fork();
    if (pid_ == 0) {
      ::dup2(out[1], 1);
      const int devnull = ::open("/dev/null", O_RDONLY);
      ::dup2(devnull, 0);
      std::vector<char*> argv;
      std::string exe_s = exe.string();
      argv.push_back(exe_s.data());
      std::vector<std::string> copy = args;
      for (auto& a : copy) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(exe_s.c_str(), argv.data());
      ::_exit(127);
    }
    ::close(out[1]);
    stdout_fd_ = out[0];
    // Wait for "ready".
    std::string seen;
    const auto deadline = Clock::now() + 15s;
    while (Clock::now() < deadline) {
      pollfd p{stdout_fd_, POLLIN, 0};
      if (::poll(&p, 1, 100) > 0) {
        char buf[256];
        const auto n = ::read(stdout_fd_, buf, sizeof buf);
        if (n <= 0) break;
        seen.append(buf, static_cast<std::size_t>(n));
        if (seen.find("ready") != std::string::npos) return true;
      }
    }
    error = "simulator did not print 'ready'; output: " + seen;
    return false;
  }
  void stop() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      int status = 0;
      ::waitpid(pid_, &status, 0);
      pid_ = -1;
    }
    if (stdout_fd_ >= 0) ::close(stdout_fd_);
    stdout_fd_ = -1;
  }
  ~SimProcess() { stop(); }

 private:
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
};

// One line to the simulator's control socket, its one-line reply back.
std::string sim_command(const fs::path& socket_path, const std::string& line) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return "error socket";
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, socket_path.c_str(), sizeof(addr.sun_path) - 1);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return "error connect";
  }
  const std::string out = line + "\n";
  if (::write(fd, out.data(), out.size()) != static_cast<ssize_t>(out.size())) {
    ::close(fd);
    return "error write";
  }
  std::string reply;
  const auto deadline = Clock::now() + 5s;
  while (Clock::now() < deadline && reply.find('\n') == std::string::npos) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;
    char buf[256];
    const auto n = ::read(fd, buf, sizeof buf);
    if (n <= 0) break;
    reply.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fd);
  if (const auto nl = reply.find('\n'); nl != std::string::npos) reply.resize(nl);
  return reply;
}

const DeviceStatus* find(const BusStatus& s, const std::string& name) {
  for (const auto& d : s.devices) {
    if (d.name == name) return &d;
  }
  return nullptr;
}

// Polls `status()` until `pred` holds or `timeout` passes; returns the time it held.
std::optional<Clock::time_point> wait_for(const BusManager& m, std::chrono::milliseconds timeout,
                                          const std::function<bool(const BusStatus&)>& pred) {
  const auto deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    if (pred(m.status())) return Clock::now();
    std::this_thread::sleep_for(2ms);
  }
  return std::nullopt;
}

std::string describe(const BusStatus& s) {
  std::string out = "bus " + s.name + " event '" + s.last_bus_event + "'\n";
  for (const auto& d : s.devices) {
    out += "  " + d.name + " node " + std::to_string(d.node_id) + " " + to_string(d.state) +
           (d.online ? " online" : " offline") + " boot-ups " + std::to_string(d.boot_ups) + " error '" +
           d.last_error + "'\n";
  }
  for (const auto& p : s.problems) out += "  problem: " + p + "\n";
  return out;
}

class BusManagerVcan : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("cobridge-busmgr-vcan-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    control_ = dir_ / "sim.sock";
    sim_ = std::make_unique<SimProcess>();
    const bool ok = sim_->start({"--iface", "vcan0",
                                 "--device", "RFC-4800:serial=" + std::to_string(kRotarySerial) + ",channels=1",
                                 "--device", "MC1-2800:serial=" + std::to_string(kMultiturnSerial) + ",node=20",
                                 "--device", "RM8000:serial=" + std::to_string(kIfmSerial) + ",node=33",
                                 "--control", control_.string(),
                                 // Non-volatile memory that survives a power cycle, as on a real device.
                                 "--state-dir", (dir_ / "sim-nv").string(),
                                 "--devices-dir", (repo_root() / "config" / "devices").string()},
                                setup_error_);
    if (!ok) return;

    const std::string toml = R"(
[gateway]
id = "vcan-test"
state_dir = ")" + (dir_ / "state").string() + R"("
control_socket = ")" + (dir_ / "control.sock").string() + R"("

[[bus]]
name = "line1"
interface = "vcan0"
discovery = true
discovery_period_s = 2
node_pool = "40-50"
commissioning = "automatic"
sdo_timeout_ms = 200
sdo_retries = 2

[[device]]
name = "rotary"
bus = "line1"
serial = )" + std::to_string(kRotarySerial) + R"(
model = "RFC-4800"
channels = 1
node_id = 10
heartbeat_ms = )" + std::to_string(kHeartbeatMs) + R"(

[[device]]
name = "multiturn"
bus = "line1"
serial = )" + std::to_string(kMultiturnSerial) + R"(
model = "MC1-2800"
node_id = 20
heartbeat_ms = )" + std::to_string(kHeartbeatMs) + R"(

[[device]]
name = "ifm"
bus = "line1"
serial = )" + std::to_string(kIfmSerial) + R"(
model = "RM8"
node_id = 33
heartbeat_ms = )" + std::to_string(kHeartbeatMs) + R"(
)";
    auto loaded = config::load_string(toml, "bus_manager_test.toml", dir_);
    if (!loaded.ok()) {
      for (const auto& d : loaded.diagnostics()) setup_error_ += d.message + "\n";
      return;
    }
    config_ = std::make_unique<config::Config>(std::move(loaded).config());
    catalog_ = std::make_unique<device::DeviceCatalog>();
    (void)catalog_->load_directory(repo_root() / "config" / "devices");
    store_ = std::make_unique<StateStore>(config_->gateway.state_dir);
    BusManagerOptions options;
    options.ready_timeout = 20s;
    manager_ = std::make_unique<BusManager>(*config_, 0, *catalog_, *store_, options);
    if (const Error e = manager_->start()) setup_error_ = "BusManager::start: " + e.to_string();
  }

  static void TearDownTestSuite() {
    const auto t = Clock::now();
    if (manager_) manager_->stop();
    stop_took_ = Clock::now() - t;
    manager_.reset();
    if (sim_) sim_->stop();
    sim_.reset();
    fs::remove_all(dir_);
  }

  void SetUp() override { ASSERT_TRUE(setup_error_.empty()) << setup_error_; }

  static inline fs::path dir_;
  static inline fs::path control_;
  static inline std::string setup_error_;
  static inline std::unique_ptr<SimProcess> sim_;
  static inline std::unique_ptr<config::Config> config_;
  static inline std::unique_ptr<device::DeviceCatalog> catalog_;
  static inline std::unique_ptr<StateStore> store_;
  static inline std::unique_ptr<BusManager> manager_;
  static inline Clock::duration stop_took_{};
};

bool all_operational(const BusStatus& s) {
  for (const char* name : {"rotary", "multiturn", "ifm"}) {
    const auto* d = find(s, name);
    if (d == nullptr || d->state != DeviceState::operational || !d->online) return false;
  }
  return true;
}

// Found (boot-up / SDO probe of 0x1018), commissioned (the rotary
// moves from its factory node-ID 127, J§1.2.2, by LSS switch selective,
// CiA 305), configured and started (CiA 301 §7.2.8.3.1 NMT start), then
// supervised by heartbeat (CiA 301 §7.2.8.3.2.2).
TEST_F(BusManagerVcan, Cia301_7_2_8_3_1_DevicesBecomeOperationalWithConfiguredNodeIds) {
  const auto ok = wait_for(*manager_, 20s, all_operational);
  const auto s = manager_->status();
  ASSERT_TRUE(ok.has_value()) << describe(s);
  EXPECT_EQ(find(s, "rotary")->node_id, 10);
  EXPECT_EQ(find(s, "multiturn")->node_id, 20);
  EXPECT_EQ(find(s, "ifm")->node_id, 33);
  EXPECT_EQ(find(s, "rotary")->identity.serial, kRotarySerial);
  EXPECT_FALSE(find(s, "rotary")->fingerprint.empty());
  EXPECT_TRUE(s.open);
  EXPECT_TRUE(manager_->serving());
  EXPECT_TRUE(manager_->ready());
  // The assignments are remembered for the next start (no new scan).
  const auto a = store_->on_bus("line1");
  EXPECT_EQ(a.size(), 3U);
}

// "A device power-cycled by the simulator is back online and
// configured within 1 s of its boot-up message" (CiA 301 §7.2.8.3.3 boot-up).
TEST_F(BusManagerVcan, Cia301_7_2_8_3_3_PowerCycledDeviceBackWithinOneSecondOfBootUp) {
  ASSERT_TRUE(wait_for(*manager_, 20s, all_operational).has_value()) << describe(manager_->status());
  const auto before = *find(manager_->status(), "multiturn");

  can::SocketCanConfig cc;
  cc.interface = "vcan0";
  can::SocketCanChannel listener(cc);
  ASSERT_FALSE(listener.open());
  const std::array<can::Filter, 1> filter{can::Filter::exact(canopen::cob::kNmtErrorControlBase + 20)};
  ASSERT_FALSE(listener.set_filters(filter));

  const std::string reply = sim_command(control_, "power-cycle " + std::to_string(kMultiturnSerial));
  ASSERT_EQ(reply.rfind("ok", 0), 0U) << reply;

  // The boot-up message: 0x714, one byte 00.
  std::optional<Clock::time_point> boot_up;
  const auto deadline = Clock::now() + 5s;
  std::array<can::Frame, 16> frames{};
  while (!boot_up && Clock::now() < deadline) {
    pollfd p{listener.fd(), POLLIN, 0};
    ::poll(&p, 1, 10);
    const auto n = listener.receive(frames);
    for (std::size_t i = 0; i < n; ++i) {
      if (frames[i].len == 1 && frames[i].data[0] == 0) boot_up = Clock::now();
    }
  }
  ASSERT_TRUE(boot_up.has_value()) << "no boot-up from node 20 after power-cycle";

  const auto back = wait_for(*manager_, 3s, [&](const BusStatus& s) {
    const auto* d = find(s, "multiturn");
    return d != nullptr && d->boot_ups > before.boot_ups && d->state == DeviceState::operational;
  });
  const auto s = manager_->status();
  ASSERT_TRUE(back.has_value()) << describe(s);
  const auto took = std::chrono::duration_cast<std::chrono::milliseconds>(*back - *boot_up);
  EXPECT_LE(took, 1000ms) << describe(s);
  EXPECT_EQ(find(s, "multiturn")->node_id, 20);
  // "A configuration fingerprint lets an unchanged device come up
  // without being rewritten": it kept its stored settings (E§11), so the
  // quick read-back found nothing to write.
  EXPECT_EQ(find(s, "multiturn")->configurations, before.configurations) << describe(s);
  bool timed = false;
  for (const auto& step : s.steps) {
    if (step.step == "back after boot-up" && step.device == "multiturn") {
      timed = true;
      EXPECT_LE(step.milliseconds, 1000.0);
    }
  }
  EXPECT_TRUE(timed) << "no 'back after boot-up' step timing";
  // Online again once its heartbeat runs.
  EXPECT_TRUE(wait_for(*manager_, 1s, [](const BusStatus& st) { return find(st, "multiturn")->online; }));
}

// "A silenced device is reported offline within its heartbeat
// consumer time, and online again when it speaks" (CiA 301 §7.2.8.3.2.2).
TEST_F(BusManagerVcan, Cia301_7_2_8_3_2_2_SilencedDeviceOfflineWithinConsumerTimeThenOnline) {
  ASSERT_TRUE(wait_for(*manager_, 20s, all_operational).has_value()) << describe(manager_->status());
  const auto consumer = consumer_time_for(std::chrono::milliseconds(kHeartbeatMs));

  std::string reply = sim_command(control_, "silence " + std::to_string(kRotarySerial) + " on");
  ASSERT_EQ(reply.rfind("ok", 0), 0U) << reply;
  const auto silenced = Clock::now();
  const auto off = wait_for(*manager_, 3s, [](const BusStatus& s) {
    const auto* d = find(s, "rotary");
    return d != nullptr && d->state == DeviceState::offline && !d->online;
  });
  auto s = manager_->status();
  ASSERT_TRUE(off.has_value()) << describe(s);
  // The last heartbeat came at most one producer period before the silence,
  // so the loss is due at most `consumer` after it; 50 ms for scheduling.
  EXPECT_LE(*off - silenced, consumer + 50ms) << describe(s);
  EXPECT_EQ(find(s, "rotary")->last_error.rfind("heartbeat lost: none for ", 0), 0U) << find(s, "rotary")->last_error;
  // The others are untouched.
  EXPECT_EQ(find(s, "ifm")->state, DeviceState::operational);

  reply = sim_command(control_, "silence " + std::to_string(kRotarySerial) + " off");
  ASSERT_EQ(reply.rfind("ok", 0), 0U) << reply;
  const auto on = wait_for(*manager_, 2s, [](const BusStatus& st) {
    const auto* d = find(st, "rotary");
    return d != nullptr && d->state == DeviceState::operational && d->online;
  });
  s = manager_->status();
  ASSERT_TRUE(on.has_value()) << describe(s);
  EXPECT_EQ(find(s, "rotary")->boot_ups, 0U);  // it never rebooted
}

// "SIGHUP reloads the config without closing the buses": only the
// device whose settings changed is configured again (new fingerprint).
TEST_F(BusManagerVcan, ReloadReconfiguresOnlyTheChangedDevice) {
  ASSERT_TRUE(wait_for(*manager_, 20s, all_operational).has_value()) << describe(manager_->status());
  const auto before = manager_->status();
  config::Config next = *config_;
  for (auto& d : next.devices) {
    if (d.name == "ifm") d.heartbeat_ms = 200;
  }
  manager_->reload(next);
  const auto done = wait_for(*manager_, 5s, [&](const BusStatus& s) {
    const auto* d = find(s, "ifm");
    return d->fingerprint != find(before, "ifm")->fingerprint && d->state == DeviceState::operational && d->online;
  });
  const auto s = manager_->status();
  ASSERT_TRUE(done.has_value()) << describe(s);
  EXPECT_EQ(find(s, "ifm")->configurations, find(before, "ifm")->configurations + 1);
  EXPECT_EQ(find(s, "rotary")->fingerprint, find(before, "rotary")->fingerprint);
  EXPECT_EQ(find(s, "rotary")->configurations, find(before, "rotary")->configurations);
  EXPECT_EQ(s.reopens, before.reopens);  // the bus stayed open
  EXPECT_TRUE(s.open);
  // The state file carries the new fingerprint for the next start.
  const auto a = store_->find("line1", find(s, "ifm")->identity.vendor, find(s, "ifm")->identity.product, kIfmSerial);
  ASSERT_TRUE(a.has_value());
  EXPECT_EQ(a->fingerprint, find(s, "ifm")->fingerprint);
}

// A device that a reload adds is shown as start-up shows a configured
// device: with the model, vendor and product its configuration names, at
// once, not blank until it is heard of (one construction path for both).
TEST_F(BusManagerVcan, ReloadAddedDeviceShowsItsConfiguredIdentityAtOnce) {
  ASSERT_TRUE(wait_for(*manager_, 20s, all_operational).has_value()) << describe(manager_->status());
  config::Config next = *config_;
  config::Device spare = next.devices.front();
  spare.name = "spare";
  spare.serial = 0x4242;
  spare.model = "MC1-2800";
  spare.vendor = 0x00000182;  // E§4.1 0x1018:1
  spare.product = 0x00000BB9;  // E§4.1 0x1018:2 (MC1-2800 before V03)
  spare.node_id = 44;
  next.devices.push_back(spare);
  manager_->reload(next);
  ASSERT_TRUE(wait_for(*manager_, 5s, [](const BusStatus& s) { return find(s, "spare") != nullptr; }).has_value())
      << describe(manager_->status());
  const auto now = manager_->status();
  const auto* d = find(now, "spare");
  EXPECT_EQ(d->model, "MC1-2800");
  EXPECT_EQ(d->identity.vendor, 0x00000182U);
  EXPECT_EQ(d->identity.product, 0x00000BB9U);
  EXPECT_EQ(d->identity.serial, 0x4242U);
  EXPECT_EQ(d->node_id, 44);
  // The other tests see the bus as configured at start.
  manager_->reload(*config_);
  ASSERT_TRUE(wait_for(*manager_, 5s, [](const BusStatus& s) { return find(s, "spare") == nullptr; }).has_value());
}

// Supervision, "bus-off and interface loss": a controller state change
// reported by an error frame (kernel SocketCAN "Network Problem
// Notifications", CAN_ERR_CRTL) shows as the bus's last event.
TEST_F(BusManagerVcan, CanRst_BusErrorShowsAsLastBusEvent) {
  ASSERT_TRUE(wait_for(*manager_, 20s, all_operational).has_value()) << describe(manager_->status());
  const std::string reply = sim_command(control_, "bus-error vcan0 error-passive");
  ASSERT_EQ(reply.rfind("ok", 0), 0U) << reply;
  const auto seen = wait_for(*manager_, 2s, [](const BusStatus& s) { return s.last_bus_event == "error-passive"; });
  EXPECT_TRUE(seen.has_value()) << describe(manager_->status());
}

// "Interface loss -> reopen with backoff and bring the devices back,
// all without restarting the process".
TEST_F(BusManagerVcan, InterfaceDownAndUpBringsDevicesBack) {
  ASSERT_TRUE(wait_for(*manager_, 20s, all_operational).has_value()) << describe(manager_->status());
  ASSERT_EQ(std::system("ip link set vcan0 down"), 0);
  const auto down = wait_for(*manager_, 3s, [](const BusStatus& s) { return s.last_bus_event == "interface-down"; });
  EXPECT_TRUE(down.has_value()) << describe(manager_->status());
  EXPECT_TRUE(wait_for(*manager_, 2s, [&](const BusStatus& st) { return !st.open; }).has_value());
  // A bus waiting for its interface is still served (its
  // thread runs): the watchdog must not restart the daemon for it.
  EXPECT_TRUE(manager_->serving());
  std::this_thread::sleep_for(500ms);  // long enough for the heartbeats to be missed
  ASSERT_EQ(std::system("ip link set vcan0 up"), 0);
  const auto back = wait_for(*manager_, 10s, [](const BusStatus& s) {
    return s.last_bus_event == "interface-reopened" && s.open && all_operational(s);
  });
  const auto s = manager_->status();
  EXPECT_TRUE(back.has_value()) << describe(s);
  EXPECT_GE(s.reopens, 1U);
  EXPECT_TRUE(manager_->serving());
}

// The bus thread ends and is joined within 1 s (SIGTERM "stops
// cleanly within 1 s"); run last.
TEST_F(BusManagerVcan, StopJoinsWithinOneSecond) {
  const auto t = Clock::now();
  manager_->stop();
  EXPECT_LT(Clock::now() - t, 1s);
  EXPECT_FALSE(manager_->serving());
}

}  // namespace
}  // namespace cobridge::bus
