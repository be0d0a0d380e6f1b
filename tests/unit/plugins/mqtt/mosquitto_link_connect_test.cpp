// A broker that is not up when the gateway starts (a plant's boot order):
// the edge node connects once it is, with the backoff docs/mqtt.md states
// (1 s doubling to 30 s). libmosquitto's own thread never retries a first
// CONNECT that failed at once; the package test's late broker found it
// (mqtt_connected 0 for good). Runs Debian's mosquitto on a free port.
#include "mosquitto_link.hpp"

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace cobridge::mqtt {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

std::uint16_t free_port() {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  EXPECT_EQ(::bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  EXPECT_EQ(::getsockname(s, reinterpret_cast<sockaddr*>(&a), &len), 0);
  ::close(s);
  return ntohs(a.sin_port);
}

bool accepts(std::uint16_t port) {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(port);
  const bool ok = ::connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  ::close(s);
  return ok;
}

// Debian's broker, local only, on `port`; killed with the object.
class Broker {
 public:
  explicit Broker(std::uint16_t port) {
    const std::string p = std::to_string(port);  // no allocation after fork
    const int null = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
    pid_ = ::fork();
    if (pid_ == 0) {
      ::dup2(null, STDOUT_FILENO);
      ::dup2(null, STDERR_FILENO);
      ::execl("/usr/sbin/mosquitto", "mosquitto", "-p", p.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    ::close(null);
  }
  ~Broker() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    ::waitpid(pid_, nullptr, 0);
  }
  Broker(const Broker&) = delete;
  Broker& operator=(const Broker&) = delete;

 private:
  pid_t pid_ = -1;
};

template <class Pred>
bool wait_for(Pred pred, std::chrono::milliseconds limit) {
  const auto end = Clock::now() + limit;
  while (!pred()) {
    if (Clock::now() > end) return false;
    std::this_thread::sleep_for(10ms);
  }
  return true;
}

class LateBroker : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists("/usr/sbin/mosquitto")) << "scripts/setup-deps installs Debian's mosquitto";
    dir = fs::temp_directory_path() / ("cobridge-late-broker-" + std::to_string(::getpid()));
    fs::create_directories(dir);
    config.port = free_port();
    config.edge_node_id = "gw1";
    config.client_id = "late-broker-test";
    config.group_id = "unit";
  }
  void TearDown() override { fs::remove_all(dir); }

  // The log is called from libmosquitto's thread too (on_connect).
  std::vector<std::string> lines() {
    const std::lock_guard<std::mutex> hold(mutex);
    return logged;
  }

  fs::path dir;
  MqttConfig config;
  std::mutex mutex;
  std::vector<std::string> logged;
  MosquittoLink::LogFn log = [this](int, const std::string& m) {
    const std::lock_guard<std::mutex> hold(mutex);
    logged.push_back(m);
  };
};

TEST_F(LateBroker, FirstConnectRetriedWithBackoffUntilTheBrokerIsUp) {
  BdSeqFile bd((dir / "bdseq").string(), log);
  bd.load();
  MosquittoLink link(config, bd, log);
  ASSERT_FALSE(link.start());  // a broker away is no error
  EXPECT_TRUE(link.awaiting_first_connect());
  const std::vector<std::string> first = lines();
  ASSERT_EQ(first.size(), 1u);
  EXPECT_NE(first[0].find("not reached yet"), std::string::npos) << first[0];

  // Due after 1 s: tried and refused again; the next try 2 s later.
  const Clock::time_point t0 = Clock::now();
  link.retry_connect(t0 + 1100ms);
  EXPECT_TRUE(link.awaiting_first_connect());

  Broker broker(config.port);
  ASSERT_TRUE(wait_for([&] { return accepts(config.port); }, 5s)) << "mosquitto -p " << config.port;
  link.retry_connect(t0 + 2500ms);  // 1.4 s after the last try: not due yet
  EXPECT_TRUE(link.awaiting_first_connect());
  link.retry_connect(t0 + 3200ms);
  EXPECT_FALSE(link.awaiting_first_connect());
  EXPECT_TRUE(wait_for([&] { return link.connected(); }, 5s));
  link.stop();
  EXPECT_FALSE(link.connected());
}

// A broker that is up: the first CONNECT starts at once, nothing to retry.
TEST_F(LateBroker, BrokerUpAtStartNeedsNoRetry) {
  Broker broker(config.port);
  ASSERT_TRUE(wait_for([&] { return accepts(config.port); }, 5s));
  BdSeqFile bd((dir / "bdseq").string(), log);
  bd.load();
  MosquittoLink link(config, bd, log);
  ASSERT_FALSE(link.start());
  EXPECT_FALSE(link.awaiting_first_connect());
  EXPECT_TRUE(wait_for([&] { return link.connected(); }, 5s));
  const std::vector<std::string> said = lines();
  EXPECT_TRUE(said.empty() || said[0].find("not reached") == std::string::npos);
}

}  // namespace
}  // namespace cobridge::mqtt
