// LSS discovery end to end, the gateway's LSS master
// (canopen::LssMaster) against cobridge-sim over a real vcan.
//
// * CiA 305 V3 Fastscan: unconfigured devices of mixed models (CI:
//   four, at the serial extremes, with the daemon's learnt waits;
//   COBRIDGE_SOAK=1, label "soak": eight, every step the full 100 ms)
//   (node=unconfigured, lss=v3) are each found exactly once, given their own
//   node-ID (0x11, J§1.5.1, E§6.1) and stored (0x17, J§1.5.3, E§6.3); after
//   a simulator restart on the same state directory they boot up on the
//   stored node-IDs. The Fastscan time per device is printed.
// * Slowscan (identify remote slave, CiA 305 0x46..0x4B): four rotary devices
//   at the factory node-ID 127 (J§1.2.2) with the V1.1.2 feature set (J§1
//   intro: no Fastscan) are told apart and given their own node-IDs.
// Runs inside UML (tests/vcan/run-in-vcan); never skips.
#include "can/socketcan_channel.hpp"
#include "canopen/clock.hpp"
#include "canopen/lss.hpp"
#include "canopen/lss_master.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

extern char** environ;

namespace cobridge {
namespace {

using canopen::Clock;
using canopen::LssAddress;
using canopen::LssMaster;
using namespace std::chrono_literals;

constexpr const char* kIface = "vcan0";
// The daemon's defaults (docs/configuration.md, lss_timeout_ms and
// lss_timeout_min_ms): a scan's first step waits 100 ms, later unanswered
// steps what the bus taught, never under 10 ms. COBRIDGE_SOAK=1 waits the
// full 100 ms at every step (nothing learnt), the slowest the master can be.
constexpr auto kLssTimeout = 100ms;
constexpr auto kLssTimeoutMin = 10ms;

bool soak_run() {
  const char* soak = std::getenv("COBRIDGE_SOAK");
  return soak != nullptr && std::string(soak) == "1";
}

LssMaster::Config search_config() {
  return LssMaster::Config{kLssTimeout, soak_run() ? kLssTimeout : kLssTimeoutMin};
}

// cobridge-sim as a child process: stdin/stdout are pipes, "ready" on stdout
// means every device is powered on.
class SimProcess {
 public:
  explicit SimProcess(const std::vector<std::string>& args) {
    int in[2], out[2];
    if (::pipe2(in, O_CLOEXEC) != 0 || ::pipe2(out, O_CLOEXEC) != 0) return;
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, in[0], 0);
    posix_spawn_file_actions_adddup2(&fa, out[1], 1);
    std::vector<char*> argv;
    std::string exe = COBRIDGE_SIM_PATH;
    argv.push_back(exe.data());
    std::vector<std::string> copy = args;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, exe.c_str(), &fa, nullptr, argv.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&fa);
    ::close(in[0]);
    ::close(out[1]);
    stdin_ = in[1];
    stdout_ = out[0];
  }
  ~SimProcess() { stop(); }
  SimProcess(const SimProcess&) = delete;
  SimProcess& operator=(const SimProcess&) = delete;

  // True once "ready" arrived within `timeout`.
  bool wait_ready(std::chrono::milliseconds timeout) {
    const auto end = Clock::now() + timeout;
    std::string got;
    while (Clock::now() < end && pid_ > 0) {
      pollfd p{stdout_, POLLIN, 0};
      if (::poll(&p, 1, 100) <= 0) continue;
      char buf[256];
      const ssize_t n = ::read(stdout_, buf, sizeof buf);
      if (n <= 0) return false;
      got.append(buf, static_cast<std::size_t>(n));
      if (got.find("ready\n") != std::string::npos) return true;
    }
    return false;
  }

  int stop() {
    if (pid_ <= 0) return -1;
    if (stdin_ >= 0) {
      (void)!::write(stdin_, "quit\n", 5);
      ::close(stdin_);
      stdin_ = -1;
    }
    int status = 0;
    for (int i = 0; i < 100; ++i) {
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        ::close(stdout_);
        return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
      }
      ::usleep(50'000);
    }
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    ::close(stdout_);
    return -1;
  }

 private:
  pid_t pid_ = -1;
  int stdin_ = -1;
  int stdout_ = -1;
};

can::SocketCanConfig channel_config() {
  can::SocketCanConfig c;
  c.interface = kIface;
  return c;
}

// Runs the LSS master until its operation ends (or `limit` passes) and feeds
// it every frame from the channel. Other frames go to `seen`.
std::optional<LssMaster::Result> drive(LssMaster& m, can::SocketCanChannel& ch, std::chrono::seconds limit,
                                       std::vector<can::Frame>* seen = nullptr) {
  const auto end = Clock::now() + limit;
  std::array<can::Frame, 64> rx{};
  while (Clock::now() < end) {
    if (!m.busy()) return m.take_result();
    const auto deadline = m.process(Clock::now());
    if (!m.busy()) return m.take_result();
    const auto wait = std::clamp(deadline - Clock::now(), Clock::duration::zero(), Clock::duration(50ms));
    pollfd p{ch.fd(), POLLIN, 0};
    (void)::poll(&p, 1, static_cast<int>(std::chrono::ceil<std::chrono::milliseconds>(wait).count()));
    const std::size_t n = ch.receive(rx);
    for (std::size_t i = 0; i < n; ++i) {
      if (!m.on_frame(rx[i], Clock::now()) && seen != nullptr) seen->push_back(rx[i]);
    }
  }
  m.cancel();
  return std::nullopt;
}

// Boot-ups (0x700+n, `00`) seen within `limit`.
std::multiset<int> collect_boot_ups(can::SocketCanChannel& ch, std::size_t want, std::chrono::seconds limit) {
  std::multiset<int> nodes;
  const auto end = Clock::now() + limit;
  std::array<can::Frame, 64> rx{};
  while (Clock::now() < end && nodes.size() < want) {
    pollfd p{ch.fd(), POLLIN, 0};
    (void)::poll(&p, 1, 100);
    const std::size_t n = ch.receive(rx);
    for (std::size_t i = 0; i < n; ++i)
      if (rx[i].id > 0x700 && rx[i].id < 0x780 && rx[i].len == 1 && rx[i].data[0] == 0)
        nodes.insert(static_cast<int>(rx[i].id - 0x700));
  }
  return nodes;
}

std::string hex(std::uint32_t v) {
  char b[16];
  std::snprintf(b, sizeof b, "0x%08X", v);
  return b;
}

std::filesystem::path fresh_dir(const std::string& name) {
  auto d = std::filesystem::temp_directory_path() / ("cobridge-lss-e2e-" + name + "-" + std::to_string(::getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

// The devices of the Fastscan test: (serial, --device argument). CI runs the
// four at the serial extremes (0x00000001, 0x7FFFFFFF, 0x80000000,
// 0xFFFFFFFE; three families); COBRIDGE_SOAK=1 (label "soak") all eight.
std::vector<std::pair<std::uint32_t, std::string>> fastscan_devices() {
  std::vector<std::pair<std::uint32_t, std::string>> all{
      {0x7FFFFFFF, "MZ1-2200:serial=0x7FFFFFFF,node=unconfigured,lss=v3"},
      {0x00000001, "RSA-3200:serial=0x00000001,node=unconfigured,lss=v3"},
      {0x80000000, "MB1-3600:serial=0x80000000,node=unconfigured,lss=v3"},
      {0xFFFFFFFE, "RM8000:serial=0xFFFFFFFE,node=unconfigured,lss=v3"},
      {0x00A10001, "MC1-2800:serial=0x00A10001,node=unconfigured,lss=v3"},
      {0x00B20002, "RFC-4800:serial=0x00B20002,node=unconfigured,lss=v3"},
      {0x00C30003, "RM9000:serial=0x00C30003,node=unconfigured,lss=v3"},
      {0x00B20003, "RFC-4800:serial=0x00B20003,node=unconfigured,lss=v3,channels=2"}};
  if (!soak_run()) all.resize(4);
  return all;
}

// Gives the device the last scan selected node-ID `node` (E§6.1, J§1.5.1),
// has it store it (E§6.3, J§1.5.3) and sends every device back to waiting.
void configure_and_store(LssMaster& confirmed, LssMaster& master, can::SocketCanChannel& ch, int node) {
  ASSERT_FALSE(confirmed.configure_node_id(static_cast<std::uint8_t>(node), Clock::now()));
  auto c = drive(confirmed, ch, 5s);
  ASSERT_TRUE(c && !c->error) << "configure node-ID " << node;
  EXPECT_EQ(c->slave_error, 0) << "J§1.5.1 error code";
  ASSERT_FALSE(confirmed.store_configuration(Clock::now()));
  c = drive(confirmed, ch, 5s);
  ASSERT_TRUE(c && !c->error) << "store configuration";
  EXPECT_EQ(c->slave_error, 0) << "J§1.5.3 error code";
  ASSERT_FALSE(master.switch_state_global(canopen::LssMode::kWaiting));
}

// CiA 305 V3 Fastscan with E§6.1, E§6.3 (configure node-ID, store):
// unconfigured devices of every family, each found once; stored IDs survive a
// restart.
TEST(LssDiscovery, Fastscan_UnconfiguredMixedDevices_E6_J1_5) {
  const auto state = fresh_dir("fastscan");
  const auto devices = fastscan_devices();
  std::vector<std::string> args{"--iface", kIface, "--state-dir", state.string()};
  std::set<std::uint32_t> serials;
  for (const auto& [serial, spec] : devices) {
    args.insert(args.end(), {"--device", spec});
    serials.insert(serial);
  }
  const int count = static_cast<int>(devices.size());
  can::SocketCanChannel ch(channel_config());
  ASSERT_FALSE(ch.open()) << "vcan0";
  std::map<std::uint32_t, int> assigned;  // serial -> node-ID
  {
    SimProcess sim(args);
    ASSERT_TRUE(sim.wait_ready(20s)) << "cobridge-sim did not start";
    LssMaster master(ch, search_config());
    // Confirmed services (configure, store) get a longer answer window than a
    // Fastscan step: the device's store writes its non-volatile memory (an
    // fsync, slow on UML's hostfs when another UML runs beside it), and only
    // silence in a scan step means "no".
    LssMaster confirmed(ch, LssMaster::Config{std::chrono::milliseconds(1000)});
    std::set<LssAddress> found;
    for (int i = 0; i < count; ++i) {
      ASSERT_FALSE(master.fastscan(Clock::now()));
      const auto r = drive(master, ch, 60s);
      ASSERT_TRUE(r.has_value()) << "Fastscan " << i << " did not finish";
      ASSERT_FALSE(r->error) << "Fastscan " << i << ": " << r->error.message();
      const LssAddress a = r->address;
      EXPECT_TRUE(found.insert(a).second) << "device found twice: serial " << hex(a.serial);
      std::printf("  Fastscan %d: vendor %s product %s revision %s serial %s in %.2f s (%u frames)\n", i + 1,
                  hex(a.vendor).c_str(), hex(a.product).c_str(), hex(a.revision).c_str(), hex(a.serial).c_str(),
                  std::chrono::duration<double>(r->elapsed).count(), r->frames_sent);
      std::fflush(stdout);
      const int node = 10 + i;
      ASSERT_NO_FATAL_FAILURE(configure_and_store(confirmed, master, ch, node));
      assigned[a.serial] = node;
    }
    // Each device exactly once: nobody is left unconfigured.
    ASSERT_FALSE(master.fastscan(Clock::now()));
    const auto none = drive(master, ch, 30s);
    ASSERT_TRUE(none.has_value());
    EXPECT_EQ(none->error, make_error_code(canopen::LssErrc::kNotFound)) << none->error.message();
    EXPECT_EQ(sim.stop(), 0);
  }
  std::set<std::uint32_t> got;
  for (const auto& [s, n] : assigned) got.insert(s);
  EXPECT_EQ(got, serials);

  // Same command line (node=unconfigured), same state directory: the stored
  // node-IDs win (J§1.5.1 "non-volatile node-ID storage").
  SimProcess again(args);
  ASSERT_TRUE(again.wait_ready(20s));
  const auto boots = collect_boot_ups(ch, devices.size(), 15s);
  std::multiset<int> want;
  for (int n = 10; n < 10 + count; ++n) want.insert(n);
  EXPECT_EQ(boots, want);
  EXPECT_EQ(again.stop(), 0);
  std::filesystem::remove_all(state);
}

// Slowscan over identify remote slave: four RFC-4800 at node 127 with the
// J§1 intro feature set (DSP-305 V1.1.2, lss=v1, no Fastscan).
TEST(LssDiscovery, Slowscan_FourRotaryAtFactoryNode127_J1_5) {
  const auto state = fresh_dir("slowscan");
  const std::vector<std::string> args{"--iface", kIface, "--state-dir", state.string(),
                                      "--device", "RFC-4800:serial=0x00001000,lss=v1",
                                      "--device", "RFC-4800:serial=0x00002345,lss=v1",
                                      "--device", "RFC-4800:serial=0x80000001,lss=v1",
                                      "--device", "RFC-4800:serial=0xFFFFFFF0,lss=v1"};
  can::SocketCanChannel ch(channel_config());
  ASSERT_FALSE(ch.open());
  SimProcess sim(args);
  ASSERT_TRUE(sim.wait_ready(20s));
  const auto boots = collect_boot_ups(ch, 4, 10s);
  EXPECT_EQ(boots, (std::multiset<int>{127, 127, 127, 127}));

  LssMaster master(ch, search_config());
  LssMaster confirmed(ch, LssMaster::Config{std::chrono::milliseconds(1000)});  // see the Fastscan test
  canopen::LssRange bounds;
  bounds.vendor = 0x00000182;
  bounds.product = 0x00000BE0;
  std::vector<std::uint32_t> order;
  for (int i = 0; i < 4; ++i) {
    ASSERT_FALSE(master.slowscan(bounds, Clock::now()));
    const auto r = drive(master, ch, 60s);
    ASSERT_TRUE(r.has_value()) << "Slowscan " << i << " did not finish";
    ASSERT_FALSE(r->error) << "Slowscan " << i << ": " << r->error.message();
    std::printf("  Slowscan %d: serial %s revision %s in %.2f s (%u frames)\n", i + 1, hex(r->address.serial).c_str(),
                hex(r->address.revision).c_str(), std::chrono::duration<double>(r->elapsed).count(), r->frames_sent);
    std::fflush(stdout);
    order.push_back(r->address.serial);
    ASSERT_NO_FATAL_FAILURE(configure_and_store(confirmed, master, ch, 20 + i));
    // Search above the one found (same revision for all four).
    bounds.rev_lo = r->address.revision;
    bounds.serial_lo = r->address.serial + 1;
    if (r->address.serial == 0xFFFFFFFFu) break;
  }
  // Smallest first: Slowscan finds the lowest address in the range.
  EXPECT_EQ(order, (std::vector<std::uint32_t>{0x00001000, 0x00002345, 0x80000001, 0xFFFFFFF0}));
  ASSERT_FALSE(master.slowscan(bounds, Clock::now()));
  const auto none = drive(master, ch, 30s);
  ASSERT_TRUE(none.has_value());
  EXPECT_EQ(none->error, make_error_code(canopen::LssErrc::kNotFound));

  // V1.1.2 has no Fastscan (J§1 intro): the rotary v1 devices never answer 0x51.
  ASSERT_FALSE(master.fastscan(Clock::now()));
  const auto fs = drive(master, ch, 10s);
  ASSERT_TRUE(fs.has_value());
  EXPECT_EQ(fs->error, make_error_code(canopen::LssErrc::kNotFound));

  // CiA 305: the configured IDs become active with NMT reset communication.
  std::array<can::Frame, 64> drain{};
  while (ch.receive(drain) > 0) {
  }
  ASSERT_TRUE(ch.send(can::Frame::make(0x000, {0x82, 0x00})));
  const auto after = collect_boot_ups(ch, 4, 10s);
  EXPECT_EQ(after, (std::multiset<int>{20, 21, 22, 23}));
  EXPECT_EQ(sim.stop(), 0);
  std::filesystem::remove_all(state);
}

}  // namespace
}  // namespace cobridge
