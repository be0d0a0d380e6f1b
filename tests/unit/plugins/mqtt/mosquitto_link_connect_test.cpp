// The MQTT client run on the publisher thread (MosquittoLink::service, no
// thread of libmosquitto's): a broker that is not up when the gateway starts
// (a plant's boot order) and a broker that goes away and comes back are
// connected again with the backoff docs/mqtt.md states (1 s doubling to
// 30 s), the new session with the next bdSeq (Sparkplug 3.0, 6.4.x bdSeq);
// a message is written at once, not on the next service() (what the 1 kHz
// p99 needs). Runs Debian's mosquitto on a free port.
#include "local_broker.hpp"
#include "mosquitto_link.hpp"

#include <mosquitto.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace cobridge::mqtt {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

using namespace test;

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

  // The bdSeq file of the test's link, loaded.
  BdSeqFile& bdseq() {
    bd_file = std::make_unique<BdSeqFile>((dir / "bdseq").string(), log);
    bd_file->load();
    return *bd_file;
  }

  // The log is called from the callbacks inside service().
  std::vector<std::string> lines() {
    const std::lock_guard<std::mutex> hold(mutex);
    return logged;
  }

  fs::path dir;
  MqttConfig config;
  std::mutex mutex;
  std::vector<std::string> logged;
  std::unique_ptr<BdSeqFile> bd_file;
  MosquittoLink::LogFn log = [this](int, const std::string& m) {
    const std::lock_guard<std::mutex> hold(mutex);
    logged.push_back(m);
  };
};

TEST_F(LateBroker, FirstConnectRetriedWithBackoffUntilTheBrokerIsUp) {
  BdSeqFile& bd = bdseq();
  MosquittoLink link(config, bd, log);
  ASSERT_FALSE(link.start());  // a broker away is no error
  EXPECT_TRUE(link.awaiting_connect());
  const std::vector<std::string> first = lines();
  ASSERT_EQ(first.size(), 1u);
  EXPECT_NE(first[0].find("not reached yet"), std::string::npos) << first[0];

  // Due after 1 s: tried and refused again; the next try 2 s later.
  const Clock::time_point t0 = Clock::now();
  link.service(t0 + 1100ms);
  EXPECT_TRUE(link.awaiting_connect());

  Broker broker(config.port);
  ASSERT_TRUE(wait_for([&] { return accepts(config.port); }, 5s)) << "mosquitto -p " << config.port;
  link.service(t0 + 2500ms);  // 1.4 s after the last try: not due yet
  EXPECT_TRUE(link.awaiting_connect());
  link.service(t0 + 3200ms);
  EXPECT_FALSE(link.awaiting_connect());
  EXPECT_TRUE(wait_for([&] { return serviced(link); }, 5s));
  link.stop();
  EXPECT_FALSE(link.connected());
}

// A broker that is up: the first CONNECT starts at once, nothing to retry.
TEST_F(LateBroker, BrokerUpAtStartNeedsNoRetry) {
  Broker broker(config.port);
  ASSERT_TRUE(wait_for([&] { return accepts(config.port); }, 5s));
  BdSeqFile& bd = bdseq();
  MosquittoLink link(config, bd, log);
  ASSERT_FALSE(link.start());
  EXPECT_FALSE(link.awaiting_connect());
  EXPECT_TRUE(wait_for([&] { return serviced(link); }, 5s));
  const std::vector<std::string> said = lines();
  EXPECT_TRUE(said.empty() || said[0].find("not reached") == std::string::npos);
}

// A broker that goes away (restart, network) and comes back: the socket's
// loss is seen by service(), the next CONNECT is due 1 s later, and the new
// session carries the next bdSeq (the broker published the old one's will).
TEST_F(LateBroker, BrokerRestartReconnectsWithTheNextBdSeq) {
  auto broker = std::make_unique<Broker>(config.port);
  ASSERT_TRUE(wait_for([&] { return accepts(config.port); }, 5s));
  BdSeqFile& bd = bdseq();
  MosquittoLink link(config, bd, log);
  ASSERT_FALSE(link.start());
  ASSERT_TRUE(wait_for([&] { return serviced(link); }, 5s));
  const MosquittoLink::State first = link.state();

  broker.reset();
  ASSERT_TRUE(wait_for([&] { return !serviced(link); }, 5s));
  EXPECT_TRUE(link.awaiting_connect());
  EXPECT_EQ(link.state().bd_seq, static_cast<std::uint8_t>(first.bd_seq + 1));
  const Clock::time_point lost = Clock::now();

  broker = std::make_unique<Broker>(config.port);
  ASSERT_TRUE(wait_for([&] { return serviced(link); }, 6s));
  EXPECT_GE(Clock::now() - lost, 900ms) << "the first retry waits 1 s";
  const MosquittoLink::State again = link.state();
  EXPECT_EQ(again.bd_seq, static_cast<std::uint8_t>(first.bd_seq + 1));
  EXPECT_EQ(again.generation, first.generation + 2) << "one session lost, one gained";
  link.stop();
}

// A test subscriber on libmosquitto's own thread: counts what arrives on `filter`.
class Subscriber {
 public:
  Subscriber(std::uint16_t port, const char* filter) : mosq_(mosquitto_new("link-test-sub", true, this)) {
    mosquitto_subscribe_callback_set(mosq_, [](mosquitto*, void* self, int, int, const int*) {
      static_cast<Subscriber*>(self)->subscribed_.store(true);
    });
    mosquitto_message_callback_set(mosq_, [](mosquitto*, void* self, const mosquitto_message*) {
      static_cast<Subscriber*>(self)->received_.fetch_add(1);
    });
    EXPECT_EQ(mosquitto_connect(mosq_, "127.0.0.1", port, 10), MOSQ_ERR_SUCCESS);
    EXPECT_EQ(mosquitto_subscribe(mosq_, nullptr, filter, 0), MOSQ_ERR_SUCCESS);
    EXPECT_EQ(mosquitto_loop_start(mosq_), MOSQ_ERR_SUCCESS);
  }
  ~Subscriber() {
    mosquitto_disconnect(mosq_);
    mosquitto_loop_stop(mosq_, false);
    mosquitto_destroy(mosq_);
  }
  Subscriber(const Subscriber&) = delete;
  Subscriber& operator=(const Subscriber&) = delete;
  [[nodiscard]] bool subscribed() const { return subscribed_.load(); }
  [[nodiscard]] int received() const { return received_.load(); }

 private:
  mosquitto* mosq_;
  std::atomic<bool> subscribed_{false};
  std::atomic<int> received_{0};
};

// publish() writes the socket itself: the subscriber has the message with
// no further service() (a threaded client only queued it for its thread).
TEST_F(LateBroker, PublishIsWrittenAtOnce) {
  Broker broker(config.port);
  ASSERT_TRUE(wait_for([&] { return accepts(config.port); }, 5s));
  BdSeqFile& bd = bdseq();
  MosquittoLink link(config, bd, log);
  ASSERT_FALSE(link.start());
  ASSERT_TRUE(wait_for([&] { return serviced(link); }, 5s));
  Subscriber sub(config.port, "spBv1.0/unit/DDATA/#");
  ASSERT_TRUE(wait_for([&] { return sub.subscribed(); }, 5s));

  const std::uint8_t payload[] = {0x08, 0x01};
  ASSERT_TRUE(link.publish("spBv1.0/unit/DDATA/gw1/enc", payload));
  EXPECT_TRUE(wait_for([&] { return sub.received() == 1; }, 5s)) << "not written without service()";
  // Nothing waits for the socket then: the publisher thread may nap.
  EXPECT_FALSE(link.wants_write());
  link.service(Clock::now());
  EXPECT_FALSE(link.wants_write());
  link.stop();
}

}  // namespace
}  // namespace cobridge::mqtt
