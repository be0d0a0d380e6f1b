// Identity probe (discovery/identity_probe): SDO upload of the CiA 301
// identity object 0x1018/1..4 to many nodes at once, answers scripted by
// hand, a fake clock. Checks what a finished round concludes per node.
#include "bus/discovery/identity_probe.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <vector>

namespace cobridge::bus::discovery {
namespace {

using namespace std::chrono_literals;
using canopen::TimePoint;

struct Recorder final : can::FrameSink {
  bool send(const can::Frame& f) noexcept override {
    sent.push_back(f);
    return true;
  }
  std::vector<can::Frame> sent;
};

struct Listener final : ProbeListener {
  void on_probed(const ProbeResult& r) override { results.push_back(r); }
  void on_round_end(bool full, canopen::Duration) override { ends.push_back(full); }
  std::vector<ProbeResult> results;
  std::vector<bool> ends;
};

// An expedited upload response (CiA 301 §7.2.4.3.3) from node `n`.
can::Frame answer(std::uint8_t n, std::uint8_t sub, std::uint32_t v) {
  return can::Frame::make8(0x580 + n, {0x43, 0x18, 0x10, sub, static_cast<std::uint8_t>(v),
                                       static_cast<std::uint8_t>(v >> 8), static_cast<std::uint8_t>(v >> 16),
                                       static_cast<std::uint8_t>(v >> 24)});
}

class IdentityProbeTest : public ::testing::Test {
 protected:
  IdentityProbeTest() : probe(sink, DiscoveryOptions{}) {
    probe.set_sdo_timeout(50ms);
    probe.set_enabled(true);
  }
  // Each device answers every sub-index request addressed to its node.
  void run_round(const std::vector<std::pair<std::uint8_t, LssAddress>>& devices) {
    for (int i = 0; i < 100 && probe.active(); ++i) {
      for (std::size_t k = seen; k < sink.sent.size(); ++k) {
        const can::Frame& req = sink.sent[k];
        const std::uint8_t n = static_cast<std::uint8_t>(req.id - 0x600);
        const std::uint8_t sub = req.data[3];
        for (const auto& [node, a] : devices)
          if (node == n) (void)probe.on_sdo_answer(answer(n, sub, a.field(static_cast<canopen::LssField>(sub - 1))), now);
      }
      seen = sink.sent.size();
      now += 30ms;
      (void)probe.drive(now, listener);
    }
  }
  Recorder sink;
  IdentityProbe probe;
  Listener listener;
  TimePoint now = TimePoint{} + 1h;
  std::size_t seen = 0;
};

TEST_F(IdentityProbeTest, OneDeviceIsIdentifiedByItsIdentityObject_CiA301_0x1018) {
  const LssAddress a{0x182, 0x0BB8, 0x10005, 4711};
  probe.want(5);
  probe.begin(now, false);
  run_round({{5, a}});
  ASSERT_EQ(listener.results.size(), 1u);
  EXPECT_EQ(listener.results[0].kind, ProbeResult::Kind::identified);
  EXPECT_TRUE(listener.results[0].changed);
  EXPECT_EQ(probe.picture()[5].ids, std::vector<LssAddress>{a});
  EXPECT_EQ(probe.present_at(a), std::optional<std::uint8_t>(5));
  EXPECT_EQ(listener.ends, std::vector<bool>{false});
}

TEST_F(IdentityProbeTest, TwoAnswersToOneRequestAreAClash_CiA305) {
  probe.want(127);
  probe.begin(now, true);
  run_round({{127, LssAddress{0x182, 0x0BE0, 3, 1001}}, {127, LssAddress{0x182, 0x0BE0, 3, 1002}}});
  ASSERT_EQ(listener.results.size(), 1u);
  const ProbeResult& r = listener.results[0];
  EXPECT_EQ(r.kind, ProbeResult::Kind::clash);
  EXPECT_EQ(r.count, 2u);
  EXPECT_TRUE(r.first_report);
  EXPECT_TRUE(probe.picture()[127].clash);
  EXPECT_EQ(probe.picture()[127].ids.size(), 2u);  // vendor/product/revision pair up
}

TEST_F(IdentityProbeTest, SilenceWhereADeviceWasMakesItAbsent) {
  const LssAddress a{0x182, 0x0BB8, 0x10005, 4711};
  probe.want(5);
  probe.begin(now, false);
  run_round({{5, a}});
  listener.results.clear();
  probe.want(5);
  probe.begin(now, false);
  run_round({});
  ASSERT_EQ(listener.results.size(), 1u);
  EXPECT_EQ(listener.results[0].kind, ProbeResult::Kind::nobody);
  EXPECT_TRUE(listener.results[0].was_known);
  EXPECT_TRUE(probe.picture()[5].ids.empty());
  EXPECT_EQ(probe.picture()[5].last, std::vector<LssAddress>{a});  // who was there last is kept
}

TEST_F(IdentityProbeTest, TwoBootUpsWithinTheWindowAreAClash_CiA301_7_2_8_3_3) {
  const auto bootup = can::Frame::make8(0x700 + 9, {0, 0, 0, 0, 0, 0, 0, 0});
  can::Frame b = bootup;
  b.len = 1;
  probe.on_error_control(b, now, true);
  probe.on_error_control(b, now + 100ms, true);
  EXPECT_TRUE(probe.take_bootups()[9]);
  probe.want(9, true);
  probe.begin(now, false);
  run_round({{9, LssAddress{0x182, 0x0BB8, 1, 1}}});
  ASSERT_EQ(listener.results.size(), 1u);
  EXPECT_EQ(listener.results[0].kind, ProbeResult::Kind::clash);
  EXPECT_EQ(listener.results[0].count, 2u);
  EXPECT_TRUE(listener.results[0].bootup);
}

TEST_F(IdentityProbeTest, BootUpsDiscoveryCausedAreNoClash_CiA301_7_2_8_3_3) {
  can::Frame b = can::Frame::make8(0x700 + 9, {0, 0, 0, 0, 0, 0, 0, 0});
  b.len = 1;
  probe.on_error_control(b, now, false);
  probe.on_error_control(b, now + 100ms, false);
  probe.want(9, true);
  probe.begin(now, false);
  run_round({{9, LssAddress{0x182, 0x0BB8, 1, 1}}});
  ASSERT_EQ(listener.results.size(), 1u);
  EXPECT_EQ(listener.results[0].kind, ProbeResult::Kind::identified);
}

TEST_F(IdentityProbeTest, DisabledProbeAsksNobody) {
  probe.set_enabled(false);
  probe.want(5);
  probe.request(6);
  EXPECT_FALSE(probe.requested());
}

}  // namespace
}  // namespace cobridge::bus::discovery
